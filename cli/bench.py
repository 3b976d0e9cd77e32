"""``mcpt bench``: timing sweeps, error against run time, plots and a Markdown report.

Thin: options in, ``bench.suite.run`` out. The benchmark code lives in the source tree's
``bench/`` folder (next to ``cli/``), not in the installed package.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mcpt.context import BACKENDS

from .main import main, reports_errors

_ROOT = Path(__file__).resolve().parent.parent


def _import_bench():
    if not (_ROOT / "bench" / "suite.py").exists():
        raise click.ClickException(
            f"mcpt bench needs the source tree's bench/ folder (looked in {_ROOT}); "
            "run it from a checkout (pip install -e .)")
    if str(_ROOT) not in sys.path:
        sys.path.insert(0, str(_ROOT))
    from bench import suite, sweeps

    return suite, sweeps


@main.command()
@click.option("--quick/--full", default=True, show_default=True,
              help="Quick: small images, a few minutes in all. Full: 256x256, 1024-spp error sweep, "
                   "4.4M-triangle level.")
@click.option("--only", "only", multiple=True, metavar="SWEEPS",
              help="Comma-separated sweeps: bounces, triangles, error, throughput (default: all).")
@click.option("-o", "--out", type=click.Path(file_okay=False, path_type=Path), default=Path("out/bench"),
              show_default=True, help="Folder for the JSON records, PNG plots and REPORT.md.")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of every render.")
@click.option("--gl-backend", type=click.Choice(BACKENDS), default=None, help="OpenGL back end.")
@click.option("--brute-cap", type=float, default=None, metavar="SECONDS",
              help="Triangle sweep: skip brute force where its projected time passes this.")
@reports_errors
def bench(quick, only, out, seed, gl_backend, brute_cap):
    """Benchmark sweeps (bounces, triangles, error vs time, paths/s) with plots and a report."""
    suite, sweeps = _import_bench()
    try:
        names = suite.resolve(list(only) or None)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--only") from None
    cfg = sweeps.config(quick, out=out, seed=seed, gl_backend=gl_backend, brute_cap_seconds=brute_cap)
    res = suite.run(names, cfg, log=lambda m: click.echo(m, err=True), argv=sys.argv)
    click.echo(res["report"])
    if res["failed"]:
        raise click.ClickException("failed sweep(s): " + "; ".join(f"{k}: {v}" for k, v in res["failed"].items()))

"""``mcpt bench``: timing sweeps, error against run time, plots and a Markdown report.

Thin: options in, ``mcpt.bench.suite.run`` out. The benchmark code lives in the source tree's
``bench/`` folder, installed as the ``mcpt.bench`` package, so it runs from a wheel too.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mcpt.gpu.context import BACKENDS

from .group import main, reports_errors


@main.command()
@click.option("--quick/--full", default=True, show_default=True,
              help="Quick: small images, a few minutes in all. Full: 256x256, 1024-spp error sweep, "
                   "4.4M-triangle level.")
@click.option("--only", "only", multiple=True, metavar="SWEEPS",
              help="Comma-separated sweeps: bounces, triangles, error, throughput (default: all), and "
                   "peer (mcpt beside Mitsuba 3; only when named).")
@click.option("-o", "--out", type=click.Path(file_okay=False, path_type=Path), default=Path("out/bench"),
              show_default=True, help="Folder for the JSON records, PNG plots and REPORT.md.")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of every render.")
@click.option("--gl-backend", type=click.Choice(BACKENDS), default=None, help="OpenGL back end.")
@click.option("--brute-cap", type=float, default=None, metavar="SECONDS",
              help="Triangle sweep: skip brute force where its projected time passes this.")
@reports_errors
def bench(quick, only, out, seed, gl_backend, brute_cap):
    """Benchmark sweeps (bounces, triangles, error vs time, paths/s) with plots and a report."""
    from mcpt.bench import suite, sweeps  # imported here: `mcpt render` need not load it

    try:
        names = suite.resolve(list(only) or None)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--only") from None
    cfg = sweeps.config(quick, out=out, seed=seed, gl_backend=gl_backend, brute_cap_seconds=brute_cap)
    res = suite.run(names, cfg, log=lambda m: click.echo(m, err=True), argv=sys.argv)
    click.echo(res["report"])
    if res["failed"]:
        raise click.ClickException("failed sweep(s): " + "; ".join(f"{k}: {v}" for k, v in res["failed"].items()))

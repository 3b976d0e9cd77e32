"""``mcpt info``: what a scene contains and what rendering it would compile and upload."""

from __future__ import annotations

import json

import click

from .group import main, reports_errors
from .options import render_options


@main.command()
@click.argument("scene_file", type=click.Path(dir_okay=False))
@render_options
@click.option("--json", "as_json", is_flag=True, help="Emit JSON on stdout.")
@click.option("--counters", is_flag=True,
              help="Also render one pass with traversal counters: node steps, triangle tests and "
                   "texel fetches per ray.")
@reports_errors
def info(scene_file, spp, bounces, seed, resolution, gl_backend, features_mode, sampler, as_json, counters):
    """Counts, BVH statistics, features, buffer sizes and GL limits of SCENE_FILE."""
    from mcpt.api import describe

    report = describe(scene_file, spp=spp, bounces=bounces, seed=seed, resolution=resolution,
                      gl_backend=gl_backend, features_mode=features_mode, sampler=sampler)
    if counters:  # a measuring tool of the benchmarks (bench/counters.py), not of the library
        from mcpt.bench.counters import measure

        report["traversal"] = measure(scene_file, seed=report["scene"]["seed"], spp=1,
                                      bounces=bounces, resolution=resolution,
                                      gl_backend=gl_backend, features_mode=features_mode)
    if as_json:
        click.echo(json.dumps(report, indent=2))
        return
    for section, body in report.items():
        if isinstance(body, dict):
            click.echo(f"{section}:")
            for k, v in body.items():
                click.echo(f"  {k}: {v}")
        else:
            click.echo(f"{section}: {body}")

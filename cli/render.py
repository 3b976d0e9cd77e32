"""``mcpt render``: scene file in, EXR or PNG out."""

from __future__ import annotations

import json
import sys
import time

import click

from mcpt import __version__

from .main import main, reports_errors
from .options import finite, positive_finite, render_options


class Progress:
    """Passes done, paths/s and time left on a terminal; silent when stderr is piped."""

    def __init__(self, pixels: int, enabled: bool):
        self.pixels, self.enabled, self.t0 = pixels, enabled, time.perf_counter()

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        dt = time.perf_counter() - self.t0
        rate = self.pixels * done / max(dt, 1e-9)
        left = dt / done * (total - done)
        bar = "#" * int(30 * done / total)
        sys.stderr.write(f"\r[{bar:<30}] {done}/{total} passes  {rate / 1e6:6.2f} Mpaths/s  "
                         f"{left:6.1f} s left ")
        if done == total:
            sys.stderr.write("\n")
        sys.stderr.flush()


@main.command()
@click.argument("scene_file", type=click.Path(dir_okay=False))
@render_options
@click.option("-o", "--output", "outputs", multiple=True, default=["out/render.exr"], show_default=True,
              help="Output image; the format follows the extension (.exr linear float, .png sRGB "
                   "8-bit). Repeat to write several files from one render.")
@click.option("--exposure", type=float, default=0.0, show_default=True, callback=finite,
              help="PNG only: exposure in stops.")
@click.option("--clamp", type=float, default=None, callback=positive_finite,
              help="BIASED: clamp each sample's largest component to this value (off by default).")
@click.option("--json", "as_json", is_flag=True, help="Print the render summary as JSON on stdout.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@reports_errors
def render(scene_file, spp, bounces, seed, resolution, gl_backend, features_mode, sampler, outputs, exposure,
           clamp, as_json, quiet):
    """Render SCENE_FILE (YAML) to an image."""
    from mcpt.api import render_scene
    from mcpt.image import check_output_path

    for output in outputs:
        check_output_path(output)  # fail before minutes of rendering, not after
    progress = Progress(1, enabled=not quiet and sys.stderr.isatty())
    result, meta = render_scene(scene_file, outputs=outputs, spp=spp, bounces=bounces, seed=seed,
                                resolution=resolution, gl_backend=gl_backend,
                                features_mode=features_mode, sampler=sampler, clamp=clamp,
                                exposure=exposure,
                                progress=progress)
    summary = {"outputs": [str(o) for o in outputs], **meta, "mcpt_version": __version__}
    if as_json:
        click.echo(json.dumps(summary, indent=2))
    else:
        click.echo(f"wrote {', '.join(outputs)}: {meta['width']}x{meta['height']}, {result.spp} spp, "
                   f"{result.bounces} bounces, {result.render_seconds:.2f} s render "
                   f"({result.paths_per_second / 1e6:.2f} Mpaths/s), set-up {meta['setup_seconds']:.2f} s"
                   + (f", {result.dropped_samples} non-finite samples dropped" if result.dropped_samples else ""),
                   err=True)

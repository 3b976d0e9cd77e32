"""``mcpt encode out/shot.####.png -o shot.mp4``: frames of a sequence to a video (issue #26,
mcpt/output/video.py; needs mcpt[video])."""

from __future__ import annotations

import click

from .group import main, reports_errors
from .options import finite, positive_finite


@main.command()
@click.argument("frames", nargs=-1, required=True)
@click.option("-o", "--output", required=True, help="The video (.mp4, H.264).")
@click.option("--fps", type=float, default=24.0, show_default=True, callback=positive_finite,
              help="Frames per second.")
@click.option("--exposure", type=float, default=0.0, show_default=True, callback=finite,
              help="EXR frames: exposure in stops (tone-mapped as the PNG output is).")
@reports_errors
def encode(frames, output, fps, exposure):
    """Encode FRAMES (a pattern with #, e.g. out/shot.####.png, or the files in order; PNG or EXR)
    to a video."""
    from mcpt.output.video import encode as encode_video
    from mcpt.output.video import pattern_files, require_ffmpeg

    require_ffmpeg()
    files = pattern_files(frames[0]) if len(frames) == 1 and "#" in frames[0] else list(frames)
    n = encode_video(files, output, fps, exposure)
    click.echo(f"wrote {output}: {n} frames at {fps:g} fps", err=True)

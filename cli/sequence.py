"""``mcpt render --frames 1-240 -o out/shot.####.exr``: an animated scene as one image per frame
(issue #26, mcpt/sequence.py). cli/render.py hands over here when ``--frames`` is given or an
output name holds ``#``; a ``.mp4`` output is encoded from the frames (cli/encode.py, mcpt[video])."""

from __future__ import annotations

import json

import click


def render_frames(scene_file, opts, frames_text, as_json: bool, quiet: bool) -> None:
    """Render the frames and print one line per frame (stderr) and a summary."""
    from mcpt.farm.signals import Interrupted, StopSignals
    from mcpt.sequence import parse_frames, render_sequence

    frames = parse_frames(frames_text) if frames_text is not None else None
    per_frame = []

    def said(rep):
        per_frame.append(rep)
        if not quiet:
            click.echo(f"frame {rep.frame}: wrote {', '.join(rep.outputs)}: {rep.spp} spp, "
                       f"{rep.render_seconds:.2f} s render, set-up {rep.setup_seconds:.3f} s", err=True)

    if opts.workers or opts.scheduler:  # one Dask task per frame (mcpt/farm/frames.py)
        from mcpt.farm.frames import sequence_on_cluster as render_sequence  # noqa: F811
    with StopSignals() as signals:
        out = render_sequence(scene_file, opts, frames, signals, on_frame=said)
    if out.interrupted is not None:
        stop = Interrupted(out.interrupted)
        click.echo(f"mcpt: interrupted by {stop.name} after {len(out.rendered)} frame(s); "
                   "run again to render the rest", err=True)
        raise SystemExit(stop.exit_code)
    summary = {"frames": out.frames, "rendered": [r.frame for r in out.rendered],
               "skipped": out.skipped, "stopped_by": out.stopped_by,
               "prepare_seconds": out.prepare_seconds, "rebuilt_per_frame": out.rebuilt,
               "per_frame": [vars(r) for r in per_frame]}
    if as_json:
        click.echo(json.dumps(summary, indent=2))
    else:
        left = len(out.frames) - len(out.rendered) - len(out.skipped)
        click.echo(f"sequence: {len(out.rendered)} frame(s) rendered, {len(out.skipped)} already done"
                   + (f", {left} left (time budget; run again to continue)" if left else ""), err=True)

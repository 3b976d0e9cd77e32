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
    videos, opts = _videos(opts)
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
    left = len(out.frames) - len(out.rendered) - len(out.skipped)
    if videos and not left:
        from mcpt.output.video import encode
        from mcpt.scene import load_scene
        from mcpt.sequence import frame_path

        fps = _fps(scene_file, opts, load_scene)
        pngs = [frame_path(next(o for o in opts.outputs if str(o).lower().endswith(".png")), f)
                for f in out.frames]
        for v in videos:
            encode(pngs, v, fps)
            if not quiet:
                click.echo(f"wrote {v}: {len(pngs)} frames at {fps:g} fps", err=True)
    summary = {"frames": out.frames, "videos": videos, "rendered": [r.frame for r in out.rendered],
               "skipped": out.skipped, "stopped_by": out.stopped_by,
               "prepare_seconds": out.prepare_seconds, "rebuilt_per_frame": out.rebuilt,
               "per_frame": [vars(r) for r in per_frame]}
    if as_json:
        click.echo(json.dumps(summary, indent=2))
    else:
        click.echo(f"sequence: {len(out.rendered)} frame(s) rendered, {len(out.skipped)} already done"
                   + (f", {left} left (time budget; run again to continue)" if left else ""), err=True)


def _videos(opts):
    """The .mp4 outputs, checked (FFmpeg installed, folder writable) before any work, and the
    options whose outputs hold a PNG pattern to encode them from (``VIDEO.frames/#####.png`` beside
    the video unless a .png pattern is given: kept, so a rerun skips the frames done)."""
    from dataclasses import replace

    from mcpt.output.video import check_video_path, is_video, require_ffmpeg

    videos = [str(o) for o in opts.outputs if is_video(o)]
    if not videos:
        return [], opts
    require_ffmpeg()
    for v in videos:
        check_video_path(v)
    images = [o for o in opts.outputs if not is_video(o)]
    if not any(str(o).lower().endswith(".png") and "#" in str(o) for o in images):
        images.append(f"{videos[0]}.frames/#####.png")
    return videos, replace(opts, outputs=images)


def _fps(scene_file, opts, load_scene) -> float:
    scene = load_scene(scene_file, overrides=tuple(opts.overrides))
    return scene.animation.fps if scene.animation is not None else 24.0

"""``mcpt render``: scene file in, EXR or PNG out; time budgets, checkpoints, resume, signals,
Dask workers. Thin: options in, the library's render loop (mcpt/render.py) out, a summary printed.
Exit codes: README "Exit codes" and cli/group.py."""

from __future__ import annotations

import json
import time

import click

from mcpt import __version__

from . import progress as progress_mod
from .group import main, reports_errors
from .options import check_farm, finite, positive_finite, render_options


@main.command()
@click.argument("scene_file", type=click.Path(dir_okay=False))
@render_options
@click.option("-o", "--output", "outputs", multiple=True, default=["out/render.exr"], show_default=True,
              help="Output image; the format follows the extension (.exr linear float, .png sRGB "
                   "8-bit). Repeat to write several files from one render.")
@click.option("-D", "overrides", multiple=True, metavar="KEY=VALUE",
              help="Override a scene key (YAML value), e.g. -D camera.resolution=[512,512] or "
                   "-D materials.white.albedo=[0.8,0.8,0.8]; repeatable; validated like the file. "
                   "A .gltf/.glb also takes -D camera=NAME (or index) to pick its camera (issue #19).")
@click.option("--exposure", type=float, default=0.0, show_default=True, callback=finite,
              help="PNG only: exposure in stops.")
@click.option("--clamp", type=float, default=None, callback=positive_finite,
              help="BIASED: clamp each sample's largest component to this value (off by default).")
@click.option("--aov", "aov_text", multiple=True, metavar="NAME[,NAME...]",
              help="EXR only (an -o .exr is needed): extra layers from the same samples: albedo "
                   "(albedo.R/G/B), normal (normal.X/Y/Z, world space), depth (depth.Z, distance "
                   "along the camera ray), variance (variance.R/G/B, of the mean); repeatable; "
                   "see 'mcpt info'.")
@click.option("--denoise", is_flag=True,
              help="BIASED: denoise with Intel Open Image Denoise (needs mcpt[denoise]) fed the "
                   "albedo and normal AOVs; the EXR keeps the raw beauty as raw.R/G/B.")
@click.option("--time", "time_budget", type=float, default=None, callback=positive_finite,
              metavar="SECONDS",
              help="Wall-time budget: stop at the draw boundary before it runs out and write the "
                   "image of the passes done (its header states them: mcpt:spp); with --checkpoint "
                   "it also leaves OUTPUT.state.npz for --resume.")
@click.option("--checkpoint", type=float, default=None, callback=positive_finite, metavar="SECONDS",
              help="Every SECONDS write the image and OUTPUT.state.npz (sums, passes, settings), "
                   "atomically; also on a stop signal and at the end.")
@click.option("--resume", is_flag=True,
              help="Continue from OUTPUT.state.npz (first -o) to the spp asked for; bit-identical "
                   "to an uninterrupted render; refuses a changed scene or setting.")
@click.option("--overwrite", is_flag=True,
              help="With --checkpoint: replace a checkpoint already at OUTPUT.state.npz (without "
                   "it, or --resume, such a render is refused: it would replace the passes there).")
@click.option("--first-pass", type=click.IntRange(min=0), default=0, show_default=True, metavar="N",
              help="Render passes N .. spp-1 of the seed only (N a multiple of 64): disjoint ranges "
                   "of one seed, rendered anywhere, `mcpt merge` into passes 0 .. spp-1.")
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="Render on a Dask LocalCluster of N worker processes (needs mcpt[farm]); "
                   "not with --scheduler.")
@click.option("--scheduler", default=None, metavar="tcp://HOST:8786",
              help="Render on an existing Dask cluster (needs mcpt[farm]); its address is probed "
                   "first (tcp:// only).")
@click.option("--progress", "progress_mode", type=click.Choice(["auto", "bar", "plain", "none"]),
              default="auto", show_default=True,
              help="'plain': one regex-friendly line every few seconds (default when stdout is not "
                   "a terminal); 'bar': redrawn on a terminal.")
@click.option("--camera", default=None, metavar="NAME",
              help="glTF only: the camera to look through, by name or index (default: the first); "
                   "the same as -D camera=NAME.")
@click.option("--frames", "frames_text", default=None, metavar="1-240|1,5,10-20",
              help="Animated scene: render these frames, one image each (-o out/shot.####.exr: "
                   "the #s are the zero-padded frame number); an output with # alone renders the "
                   "scene's animation.frames (issue #26, cli/sequence.py).")
@click.option("--json", "as_json", is_flag=True, help="Print the render summary as JSON on stdout.")
@click.option("--quiet", is_flag=True, help="No progress output.")
@reports_errors
def render(scene_file, spp, bounces, seed, resolution, gl_backend, features_mode, sampler, outputs,
           overrides, exposure, clamp, aov_text, denoise, time_budget, checkpoint, resume, overwrite,
           first_pass, workers, scheduler, camera, progress_mode, as_json, quiet, frames_text):
    """Render SCENE_FILE (YAML, Mitsuba 3 XML, glTF 2.0 .gltf/.glb) to an image."""
    started = time.perf_counter()
    from mcpt.api import Options
    from mcpt.api import render as render_loop
    from mcpt.farm.signals import StopSignals
    from mcpt.gpu.aov import parse as parse_aovs

    if camera is not None:
        if not scene_file.lower().endswith((".gltf", ".glb")):
            raise click.BadParameter("only a glTF scene (.gltf, .glb) names its cameras",
                                     param_hint="--camera")
        overrides = (*overrides, f"camera={camera}")  # the glTF reader's option (mcpt/scene/gltf)
    check_farm(workers, scheduler)
    aovs = parse_aovs(aov_text)  # repeated --aov accumulate (issue #24 item 19: the last one won)
    if aovs and not any(str(o).lower().endswith(".exr") for o in outputs):
        # issue #24 item 19: the AOVs were computed and dropped (a PNG has no layers)
        raise click.BadParameter(f"AOV layers are written to an EXR only; add -o NAME.exr (outputs: "
                                 f"{', '.join(outputs)})", param_hint="--aov")
    prog = progress_mod.make(progress_mode, quiet)
    opts = Options(list(outputs), spp=spp, bounces=bounces, seed=seed, resolution=resolution,
                   gl_backend=gl_backend, features_mode=features_mode, sampler=sampler, clamp=clamp,
                   exposure=exposure, aovs=aovs, denoise=denoise,
                   time_budget=time_budget, checkpoint=checkpoint, resume=resume,
                   overwrite=overwrite,
                   first_pass=first_pass, overrides=tuple(overrides), workers=workers,
                   scheduler=scheduler, progress=prog, started=started)
    if frames_text is not None or any("#" in str(o) or str(o).lower().endswith(".mp4")
                                      for o in outputs):  # issue #26: a sequence
        from .sequence import render_frames

        return render_frames(scene_file, opts, frames_text, as_json, quiet)
    with StopSignals() as signals:
        out = render_loop(scene_file, opts, signals)
    if prog is not None:
        prog.close()
    result, meta = out.result, out.meta
    if out.interrupted is not None:
        from mcpt.farm.signals import Interrupted

        stop = Interrupted(out.interrupted)
        kept = (f"checkpoint {out.checkpoint} ({result.spp} passes; continue with --resume)"
                if out.checkpoint else "nothing written")
        click.echo(f"mcpt: interrupted by {stop.name} after {result.spp}/{out.spp_requested} "
                   f"passes: {kept}", err=True)
        raise SystemExit(stop.exit_code)
    summary = {"outputs": [str(o) for o in outputs], **meta, "spp_requested": out.spp_requested,
               "resumed_from": out.resumed_from, "stopped_by": out.stopped_by,
               "checkpoint": str(out.checkpoint) if out.checkpoint else None,
               **({"farm": out.farm} if out.farm else {}),
               "aovs": list(opts.aovs), "denoised": denoise,
               "mcpt_version": __version__}
    if as_json:
        click.echo(json.dumps(summary, indent=2))
    else:
        budget = (f" (time budget: {result.spp} of {out.spp_requested} spp)"
                  if out.stopped_by == "time" else "")
        click.echo(f"wrote {', '.join(outputs)}: {meta['width']}x{meta['height']}, {result.spp} spp"
                   f"{budget}, {result.bounces} bounces, {result.render_seconds:.2f} s render "
                   f"({meta['paths_per_second'] / 1e6:.2f} Mpaths/s), set-up {meta['setup_seconds']:.2f} s"
                   + (f", {result.dropped_samples} non-finite samples dropped" if result.dropped_samples else "")
                   + (", denoised (OIDN, biased)" if denoise else ""),
                   err=True)

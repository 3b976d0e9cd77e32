"""The library's entry points: what the CLI, the benchmarks and a Python user call.

    prepare        read -> build -> derive -> pack -> compile (mcpt/prepare.py): a Prepared scene
    render         the render loop (mcpt/render.py): prepare, passes, checkpoints, write
    run            the same loop on a scene prepared once (benchmarks render it many times)
    render_scene   one call: a scene in, images out (``render`` with keyword arguments)
    describe       what ``mcpt info`` shows of a prepared scene
    render_sequence  the frames of an animated scene (mcpt/sequence.py), each through ``run``
    at_frame       an animated scene at frame N (mcpt/scene/frame.py): a still of it is frame N

Every render goes through mcpt/render.py; nothing here draws a pass itself.
"""

from __future__ import annotations

from pathlib import Path

from .gpu.aov import AOVS
from .gpu.aov import parse as parse_aovs
from .prepare import Prepared, prepare
from .render import Options, Outcome, render, run
from .scene.frame import at_frame
from .sequence import render_sequence
from .shading.camera import camera_summary
from .shading.lights import describe_lights

__all__ = ["Options", "Outcome", "Prepared", "at_frame", "describe", "prepare", "render", "render_scene",
           "render_sequence", "run"]


def render_scene(scene, *, outputs=(), spp=None, bounces=None, seed=None, resolution=None,
                 gl_backend=None, features_mode="scene", clamp=None, exposure=0.0, progress=None,
                 sampler=None, aovs=(), denoise=False):
    """Render a scene (file or Scene), write each of ``outputs``; returns (result, metadata).
    ``aovs``: names from mcpt.gpu.aov.AOVS written as EXR layers; ``denoise``: OIDN (biased);
    ``progress(summed, spp, passes_this_run, seconds)`` after every draw."""
    outputs = [outputs] if isinstance(outputs, (str, Path)) else list(outputs)
    opts = Options(outputs, spp=spp, bounces=bounces, seed=seed, resolution=resolution,
                   gl_backend=gl_backend, features_mode=features_mode, sampler=sampler, clamp=clamp,
                   exposure=exposure, aovs=parse_aovs(aovs), denoise=denoise, progress=progress)
    out = render(scene, opts)
    return out.result, out.meta


def describe(scene, **kwargs) -> dict:
    """Everything ``mcpt info`` shows: counts, BVH, features, buffer bytes, GL limits.
    ``kwargs`` go to :func:`prepare`."""
    p = prepare(scene, **kwargs)
    try:
        cam, r = p.scene.camera, p.renderer
        return {
            "scene": {"file": str(p.scene.source_path), "name": p.scene.name or "",
                      "resolution": [cam.width, cam.height], "spp": p.scene.render.spp,
                      "bounces": p.features.bounces, "seed": p.scene.render.seed},
            "counts": {k: v for k, v in p.world.stats.items() if k != "bvh"},
            "lights": describe_lights(p.world.lights, p.scene),
            "bvh": p.world.bvh.stats(),
            "camera": camera_summary(cam),
            "features": {"key": dict(p.features.key), "defines": p.features.defines()},
            "buffers": {**r.setup["upload_bytes"], "random_per_pass": r.setup["random_bytes_per_pass"]},
            "gl": {**p.gl.describe(), **p.gl.limits()},
            "aovs": {name: f"{','.join(f'{name}.{c}' for c in ch)}: {what}"
                     for name, (ch, what) in AOVS.items()},
            "setup": {"compile_seconds": r.setup["compile_seconds"],
                      "upload_seconds": r.setup["upload_seconds"],
                      "tiles": r.setup["tiles"], "total_seconds": p.setup_seconds},
        }
    finally:
        p.renderer.release()

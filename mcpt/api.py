"""High-level entry points used by the CLI, the benchmarks and the tests.

The walk from a scene file to pixels, each room entered once, in this order:

    load      mcpt.scene.load_scene            YAML -> validated Scene (+ command-line overrides)
    build     mcpt.shapes.world.load_world     meshes, materials, BVH, lights -> World
    derive    mcpt.gpu.features.for_world      what the world needs -> Features (the define set)
    pack      mcpt.gpu.pack.pack               World + Features -> buffers and uniforms
    compile   mcpt.gpu.render.Renderer         limits checked, program compiled, buffers uploaded
    render    Renderer.render                  passes averaged in float64
    write     mcpt.output.image.write_image    EXR / PNG, atomically

``prepare`` does the first five; ``render_scene`` adds the passes and writes the images.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from . import __version__
from .gpu.context import GLContext, shared_context
from .gpu.aov import AOVS
from .gpu.aov import parse as parse_aovs
from .gpu.features import Features, for_world, loop_limit_for
from .gpu.pack import pack
from .gpu.render import Renderer, RenderResult
from .output.denoise import version as denoiser_version
from .output.image import check_output_path, write_image
from .output.layers import computed as computed_aovs
from .output.layers import feature_flags as aov_flags
from .output.layers import finish
from .scene import Scene, load_scene
from .shapes.world import World, load_world

@dataclass
class Prepared:
    gl: GLContext
    scene: Scene
    world: World
    features: Features
    renderer: Renderer
    setup_seconds: float


def prepare(scene: Scene | str | Path, *, spp=None, bounces=None, seed=None, resolution=None,
            gl_backend=None, features_mode: str = "scene", clamp: float | None = None,
            feature_flags: dict | None = None, sampler: str | None = None, aovs=()) -> Prepared:
    """``aovs``: the AOVs to compute (mcpt/gpu/aov.py; for --denoise include albedo and normal)."""
    t0 = time.perf_counter()
    if not isinstance(scene, Scene):
        scene = load_scene(scene)
    scene = scene.with_overrides(spp=spp, bounces=bounces, seed=seed, resolution=resolution)
    gl = shared_context(gl_backend)
    world = load_world(scene)
    flags = {"loop_limit": loop_limit_for(gl.renderer), **aov_flags(aovs, False), **(feature_flags or {})}
    if sampler is not None:
        flags["sampler"] = sampler
    feats = for_world(world, clamp=clamp is not None, **flags)
    if features_mode == "all":
        feats = feats.everything()
    renderer = Renderer(gl, feats, pack(world, feats), clamp=clamp)
    return Prepared(gl, scene, world, feats, renderer, time.perf_counter() - t0)


def metadata(p: Prepared, result: RenderResult) -> dict:
    cam = p.scene.camera
    return {
        "scene": str(p.scene.source_path) if p.scene.source_path else (p.scene.name or ""),
        "width": cam.width, "height": cam.height, "spp": result.spp, "bounces": result.bounces,
        "seed": result.seed, "render_seconds": result.render_seconds,
        "random_seconds": result.random_seconds, "setup_seconds": p.setup_seconds,
        "paths_per_second": result.paths_per_second, "dropped_samples": result.dropped_samples,
        "gl_backend": p.gl.backend, "gl_renderer": p.gl.renderer, "gl_version": p.gl.version,
        "features": {k: v for k, v in p.features.defines().items()},
        "triangles": p.world.n_triangles, "mcpt_version": __version__,
        **{k: v for k, v in result.setup.items()},
    }


def header_keys(meta: dict) -> dict:
    """Metadata as EXR header keys: ``mcpt:``-prefixed, nested dicts as their repr."""
    return {f"mcpt:{k}": (v if not isinstance(v, dict) else repr(v)) for k, v in meta.items()}


def render_scene(scene, *, outputs=(), spp=None, bounces=None, seed=None, resolution=None,
                 gl_backend=None, features_mode="scene", clamp=None, exposure=0.0, progress=None,
                 sampler=None, aovs=(), denoise=False):
    """Render a scene (file or Scene), write each of ``outputs``; returns (result, metadata).
    ``aovs``: names from mcpt.gpu.aov.AOVS written as EXR layers; ``denoise``: OIDN (biased)."""
    outputs = [outputs] if isinstance(outputs, (str, Path)) else list(outputs)
    for output in outputs:
        check_output_path(output)
    aovs = parse_aovs(aovs)
    if denoise:
        denoiser_version()  # no denoiser: one clear error before minutes of rendering
    p = prepare(scene, spp=spp, bounces=bounces, seed=seed, resolution=resolution,
                gl_backend=gl_backend, features_mode=features_mode, clamp=clamp, sampler=sampler,
                aovs=computed_aovs(aovs, denoise))
    if progress is not None and hasattr(progress, "pixels"):
        progress.pixels = p.scene.camera.width * p.scene.camera.height
    rs = p.scene.render
    result = p.renderer.render(rs.spp, rs.seed, progress=progress)
    meta = metadata(p, result)
    p.renderer.release()
    exr_meta = header_keys(meta)
    image, layers, extra = finish(result, aovs, denoise)
    exr_meta.update(extra)
    for output in outputs:
        write_image(output, image, exr_meta, exposure, layers=layers)
    return result, meta


def describe(scene, counters: bool = False, **kwargs) -> dict:
    """Everything ``mcpt info`` shows: counts, BVH, features, buffer bytes, GL limits; with
    ``counters``, also the traversal work per ray of one pass (mcpt/gpu/counters.py)."""
    p = prepare(scene, **kwargs)
    try:
        cam = p.scene.camera
        out = {
            "scene": {"file": str(p.scene.source_path), "name": p.scene.name or "",
                      "resolution": [cam.width, cam.height], "spp": p.scene.render.spp,
                      "bounces": p.features.bounces, "seed": p.scene.render.seed},
            "counts": {k: v for k, v in p.world.stats.items() if k != "bvh"},
            "bvh": p.world.bvh.stats(),
            "features": {"key": dict(p.features.key), "defines": p.features.defines()},
            "buffers": {**{k: v for k, v in p.renderer.setup["upload_bytes"].items()},
                        "random_per_pass": p.renderer.setup["random_bytes_per_pass"]},
            "gl": {**p.gl.describe(), **p.gl.limits()},
            "aovs": {name: f"{','.join(f'{name}.{c}' for c in ch)}: {what}"
                     for name, (ch, what) in AOVS.items()},
            "setup": {"compile_seconds": p.renderer.setup["compile_seconds"],
                      "upload_seconds": p.renderer.setup["upload_seconds"],
                      "tiles": p.renderer.setup["tiles"], "total_seconds": p.setup_seconds},
        }
    finally:
        p.renderer.release()
    if counters:
        from .gpu.counters import measure

        keep = ("gl_backend", "features_mode")  # p.scene already holds the other overrides
        out["traversal"] = measure(p.scene, seed=p.scene.render.seed,
                                   **{k: v for k, v in kwargs.items() if k in keep and v is not None})
    return out

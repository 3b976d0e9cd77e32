"""From a scene file to a compiled program with the scene uploaded: everything before the passes.

    read      mcpt.scene.load_scene            YAML -> validated Scene (+ -D and command-line overrides)
    size      mcpt.gpu.scene_size              its triangles counted from headers, refused past the limit
    build     mcpt.shapes.world.load_world     meshes, materials, BVH, lights -> World
              (through mcpt.shapes.world_cache: a scene built before is read back from disk)
    derive    mcpt.gpu.features.for_world      what the world needs -> Features (the define set)
    pack      mcpt.gpu.pack.pack               World + Features -> buffers and uniforms
              (through mcpt.gpu.pack_cache where the world came through the cache)
    compile   mcpt.gpu.render.Renderer         limits checked, program compiled, buffers uploaded

The render loop (mcpt/render.py) calls :func:`prepare` once per render, a farm worker
(mcpt/farm/worker.py) once per job; ``mcpt info`` (mcpt.api.describe) reports what it made.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from .farm.state import scene_hash
from .gpu import wavefront
from .gpu.context import GLContext, shared_context
from .gpu.features import Features, for_world, loop_limit_for
from .gpu.options import DispatchError, dispatch_flags
from .gpu.pack import pack
from .gpu.pack_cache import cached_pack
from .gpu.render import Renderer
from .gpu.scene_size import check_scene_size
from .heap import setup_heap
from .output.layers import feature_flags as aov_flags
from .scene import Scene, SceneError, load_scene
from .shading.camera import check_camera
from .shading.environment import check_environment_file
from .shapes.world import World, load_world
from .shapes.world_cache import cached_world


@dataclass
class Prepared:
    """A scene ready for passes, and the settings it was prepared with (what a checkpoint records
    and what a farm worker needs to prepare the same program)."""

    gl: GLContext
    scene: Scene                  # overrides applied: scene.render.spp / seed are the render's
    world: World
    features: Features
    renderer: Renderer
    setup_seconds: float
    features_mode: str = "scene"
    clamp: float | None = None
    aovs: tuple = ()              # the AOVs computed (mcpt/output/layers.py computed)
    overrides: tuple = ()         # -D KEY=VALUE applied when the scene file was read
    gl_backend: str | None = None  # as asked (None: $MCPT_GL_BACKEND or auto); gl.backend: the one used
    scene_hash: str | None = None  # of the files as the world was built from them (farm/state.py)


def prepare(scene: Scene | str | Path, *, spp=None, bounces=None, seed=None, resolution=None,
            gl_backend=None, features_mode: str = "scene", clamp: float | None = None,
            feature_flags: dict | None = None, sampler: str | None = None, aovs=(),
            overrides=(), cache: bool | None = None) -> Prepared:
    """``aovs``: the AOVs to compute (mcpt/gpu/aov.py; for --denoise include albedo and normal);
    ``overrides``: ``-D KEY=VALUE`` strings, applied when ``scene`` is a file to read; ``cache``:
    read and keep the built world in the on-disk cache (mcpt/cache.py; None: unless
    ``MCPT_CACHE=0``)."""
    t0 = time.perf_counter()
    if not isinstance(scene, Scene):
        scene = load_scene(scene, overrides=tuple(overrides))
    scene = scene.with_overrides(spp=spp, bounces=bounces, seed=seed, resolution=resolution)
    check_scene_size(scene)  # issue #24: before any geometry is read or tessellated
    gl = shared_context(gl_backend)
    # issue #20: an environment map too large for this driver or this machine, from its header
    check_environment_file(scene.environment, scene.where("environment", "file"),
                           gl.limits()["max_texture_buffer_size"])
    # The hash a checkpoint, an EXR header and every farm worker check is that of the files this
    # world was built from (issue #24: a mesh edited during a farm render was drawn by the workers
    # while the header recorded the original): taken before and after reading them, and refused
    # when they changed in between.
    digest = scene_hash(scene)
    with setup_heap():  # big temporaries reuse freed memory (mcpt/heap.py)
        world = cached_world(scene, load_world, cache)
        if scene_hash(scene) != digest:
            raise SceneError(str(scene.source_path or "<scene>"), None, "",
                             "a file of the scene changed while it was read; render again")
        check_camera(scene, world.tris)
        flags = {"loop_limit": loop_limit_for(gl.renderer), **dispatch_flags(),
                 **aov_flags(aovs, False), **(feature_flags or {})}
        if sampler is not None:
            flags["sampler"] = sampler
        feats = for_world(world, clamp=clamp is not None, **flags)
        if features_mode == "all":
            feats = feats.everything()
        if feats.wavefront and (missing := wavefront.unsupported(feats)):
            raise DispatchError(f"MCPT_DISPATCH=wavefront cannot render {missing}; use fragment or compute")
        renderer = Renderer(gl, feats, cached_pack(world, feats, pack, cache), clamp=clamp)
    return Prepared(gl, scene, world, feats, renderer, time.perf_counter() - t0, features_mode,
                    clamp, tuple(aovs), tuple(overrides), gl_backend, digest)

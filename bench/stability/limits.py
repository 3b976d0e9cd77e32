"""GL limits: refused before compiling, with the limit quoted."""

from __future__ import annotations

import numpy as np

from mcpt.gpu.pack import pack
from mcpt.scene.shipped import shipped
from mcpt.shading.sampler import dims_for

from .core import Env, Outcome, case
from .scale import cornell_scene

SPHERE_OBJ = shipped("furnace/sphere_inward.obj")
CORNELL_YAML = shipped("cornell-box.yaml")
FURNACE_YAML = shipped("furnace.yaml")
FLT_MAX = float(np.finfo(np.float32).max)



# ---- GL limits -------------------------------------------------------------------------------

class LimitedGL:
    """A GL context that reports smaller limits (everything else delegated): how mcpt behaves on
    a GPU whose limits are lower than llvmpipe's, without allocating gigabytes here."""

    def __init__(self, gl, **limits):
        self._gl, self._limits = gl, limits

    def limits(self) -> dict:
        return {**self._gl.limits(), **self._limits}

    def __getattr__(self, name):
        return getattr(self._gl, name)


@case("tbo-over-limit-refused", "limits")
def _tbo_limit(env: Env) -> Outcome:
    """The Cornell box on a GPU that allows only 100 buffer texels: refused, limit quoted."""
    from mcpt.api import prepare
    from mcpt.gpu.render import Renderer
    from mcpt.gpu.tbo import TBOError

    p = prepare(cornell_scene(env, "tbo-limit", res=8), gl_backend=env.gl_backend)
    p.renderer.release()
    try:
        Renderer(LimitedGL(p.gl, max_texture_buffer_size=100), p.features, pack(p.world, p.features)).release()
        return Outcome("TBOError quoting GL_MAX_TEXTURE_BUFFER_SIZE = 100", "accepted", False)
    except TBOError as exc:
        msg = str(exc)
        ok = "GL_MAX_TEXTURE_BUFFER_SIZE = 100" in msg and "fit" in msg
        return Outcome("TBOError quoting GL_MAX_TEXTURE_BUFFER_SIZE = 100", msg, ok)


@case("tbo-limit-queried", "limits")
def _tbo_limit_real(env: Env) -> Outcome:
    """The real limit is read from the driver and one texel over it is refused before upload."""
    from mcpt.gpu.tbo import TBOError, check_size

    limit = env.gl.limits()["max_texture_buffer_size"]
    try:
        check_size(env.gl, "tris", limit + 1, 3, "triangles")
        refused = "accepted"
    except TBOError as exc:
        refused = str(exc)
    ok = limit >= 65536 and str(limit) in refused
    return Outcome(">= 65536 (GL minimum), limit + 1 refused", f"{limit}; {refused}", ok)


@case("resolution-over-scene-limit", "limits")
def _resolution_scene(env: Env) -> Outcome:
    """--resolution 16385x16 is refused by the scene validation, naming the key and the limit."""
    from mcpt.scene import MAX_RESOLUTION, SceneError, load_scene

    try:
        load_scene(FURNACE_YAML).with_overrides(resolution=(MAX_RESOLUTION + 1, 16))
        return Outcome(f"SceneError quoting {MAX_RESOLUTION}", "accepted", False)
    except SceneError as exc:
        msg = str(exc)
        return Outcome(f"SceneError naming camera.resolution and {MAX_RESOLUTION}", msg,
                       "resolution" in msg and str(MAX_RESOLUTION) in msg)


@case("resolution-over-gl-limit", "limits")
def _resolution_gl(env: Env) -> Outcome:
    """A 64x64 image on a GPU whose textures and viewport stop at 32: refused with the limit."""
    from mcpt.api import prepare
    from mcpt.gpu.render import Renderer, RenderError

    p = prepare(cornell_scene(env, "gl-size", res=64), gl_backend=env.gl_backend)
    p.renderer.release()
    try:
        Renderer(LimitedGL(p.gl, max_texture_size=32, max_viewport_dims=[32, 32]), p.features,
                 pack(p.world, p.features)).release()
        return Outcome("RenderError quoting the limit 32", "accepted (64x64 targets allocated)", False)
    except RenderError as exc:
        return Outcome("RenderError quoting the limit 32", str(exc), "32" in str(exc))


@case("random-row-over-buffer-limit", "limits")
def _random_row(env: Env) -> Outcome:
    """16384 pixels x (2 + 6 x 1000 bounces) random numbers per image row exceed one buffer:
    refused before any allocation, with both numbers."""
    from mcpt.gpu.render import RenderError, plan_tiles

    limit = env.gl.limits()["max_texture_buffer_size"]
    dims = dims_for(1000)
    try:
        plan_tiles(16384, 16, dims, limit)
        return Outcome("RenderError", "accepted", False)
    except RenderError as exc:
        msg = str(exc)
        return Outcome(f"RenderError quoting {16384 * dims}", msg, str(16384 * dims) in msg)

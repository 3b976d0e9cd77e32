"""Texture Buffer Objects: ``(N, 4)`` numpy arrays -> ``samplerBuffer``/``usamplerBuffer`` in GLSL.

moderngl has no buffer-texture type and silently ignores ``samplerBuffer`` uniforms, so the texture
is made with raw ``glGenTextures`` / ``glTexBuffer`` through :class:`mcpt.context.GLContext` and bound
to a FIXED texture unit that the GLSL declares with ``layout(binding = N)``. Units are assigned in
:data:`UNITS`; they stay far below moderngl's scratch unit (the last one).

Everything mcpt packs is RGBA32UI: integers stay integers and float32 values travel as raw bits
(``uintBitsToFloat`` in GLSL). That keeps ints out of the float path, where llvmpipe flushes
denormals (a small int read as float bits is a denormal) -- the round trip is bit-exact.
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass

import numpy as np

from ..errors import McptError
from .context import GL_TEXTURE0, GL_TEXTURE_BUFFER, GLContext

GL_RGBA32F = 0x8814
GL_RGBA32UI = 0x8D70
GL_R32UI = 0x8236
GL_R32F = 0x822E

# Texture unit of every buffer the shaders read; the GLSL side uses the same numbers
# (glsl/*.glsl `layout(binding = N)`), checked by tests/test_shader.py.
UNITS = {
    "nodes": 1,       # BVH interior nodes (4 texels) and triangles (3) (mcpt/shapes/bvh.py BVH.gpu_nodes)
    "tris": 2,        # triangle vertices, 3 texels each (mcpt/shapes/geometry.py)
    "lights": 3,      # light table, 1 texel per light + punctual data (mcpt/shading/lights.py)
    "materials": 4,   # material table, 2 or 4 texels each (mcpt/shading/materials.py)
    "random": 5,      # per-pass random numbers, 1 float each (mcpt/shading/sampler.py)
    "normals": 7,     # smooth-shading corner normals, 1 texel per triangle (mcpt/shading/normals.py)
    "uvs": 8,         # texture coordinates, 2 texels per triangle (mcpt/shading/texture.py)
    "textures": 9,    # albedo images: headers + sRGB texels (mcpt/shading/texture.py)
    "env_texels": 10,  # environment map radiance + cell pdfs, 1 texel each (mcpt/shading/envmap.py)
    "env_alias": 11,   # environment map alias tables (rows, then each row's cells), 2 entries a texel
    "tangents": 12,    # normal maps: corner tangents, 1 texel per triangle (mcpt/shading/normal_map.py)
    "normal_maps": 13,  # normal maps: texture id and scale, 1 texel per material (ditto)
    "spheres": 15,     # analytic spheres, 5 texels each (mcpt/shapes/sphere.py)
    "emit_pdf": 14,    # emission textures: pmf / area per triangle, 4 a texel (mcpt/shading/emission_texture.py)
}


class TBOError(McptError, ValueError):
    """A buffer does not fit the GL limits; the message says what would fit."""


@dataclass
class TBO:
    """One buffer texture: the moderngl buffer that holds the data and the GL texture viewing it."""

    name: str
    unit: int
    texels: int
    nbytes: int
    buffer: object
    texture: int
    internal_format: int
    _gl: GLContext

    def bind(self) -> None:
        gl = self._gl
        gl.fn("glActiveTexture", None, ctypes.c_uint)(GL_TEXTURE0 + self.unit)
        gl.fn("glBindTexture", None, ctypes.c_uint, ctypes.c_uint)(GL_TEXTURE_BUFFER, self.texture)

    def write(self, array: np.ndarray) -> None:
        """Replace the contents with an array of exactly the same size (e.g. fresh random numbers)."""
        data = _as_texels(array, self.internal_format)
        if data.nbytes != self.nbytes:
            raise TBOError(f"{self.name}: write of {data.nbytes} bytes into a {self.nbytes}-byte buffer")
        self.buffer.write(data)

    def release(self) -> None:
        tex = ctypes.c_uint(self.texture)
        self._gl.fn("glDeleteTextures", None, ctypes.c_int, ctypes.POINTER(ctypes.c_uint))(
            1, ctypes.byref(tex))
        self.buffer.release()


def _as_texels(array: np.ndarray, internal_format: int) -> np.ndarray:
    a = np.ascontiguousarray(array)
    if internal_format == GL_R32UI:
        want = np.uint32
    elif internal_format == GL_R32F:
        want = np.float32
    elif internal_format == GL_RGBA32F:
        want = np.float32
    else:
        want = np.uint32
    if a.dtype == np.float32 and want == np.uint32:
        a = a.view(np.uint32)  # float bits travel unchanged
    if a.dtype != want:
        raise TBOError(f"TBO data must be float32 or uint32, got {a.dtype}")
    if internal_format not in (GL_R32UI, GL_R32F) and (a.ndim != 2 or a.shape[1] != 4):
        raise TBOError(f"TBO data must have shape (N, 4), got {a.shape}")
    return a


def check_size(gl: GLContext, name: str, texels: int, per_item: int = 1, item: str = "items") -> None:
    """Refuse a buffer larger than GL_MAX_TEXTURE_BUFFER_SIZE (llvmpipe does not clamp: we must)."""
    limit = gl.limits()["max_texture_buffer_size"]
    if texels > limit:
        raise TBOError(f"{name}: {texels} texels exceed GL_MAX_TEXTURE_BUFFER_SIZE = {limit} on "
                       f"{gl.renderer}; at most {limit // per_item} {item} fit")


def create_tbo(gl: GLContext, name: str, array: np.ndarray, *, unit: int | None = None,
               internal_format: int = GL_RGBA32UI, per_item: int = 1, item: str = "items") -> TBO:
    """Upload ``array`` ((N,4) uint32/float32 bits; (N,) for R32UI/R32F) as a buffer texture.

    ``per_item`` texels make one ``item`` (e.g. 3 texels per triangle) so a size error can say how
    many items fit.
    """
    data = _as_texels(array, internal_format)
    texels = max(data.shape[0], 1)
    check_size(gl, name, texels, per_item, item)
    if data.size == 0:  # GL needs a non-empty store; shaders never read an empty table
        data = np.zeros((1,) if data.ndim == 1 else (1, 4), data.dtype)
    buf = gl.ctx.buffer(np.ascontiguousarray(data))  # the array's own memory: no tobytes copy (issue #23)
    tex = ctypes.c_uint()
    gl.fn("glGenTextures", None, ctypes.c_int, ctypes.POINTER(ctypes.c_uint))(1, ctypes.byref(tex))
    tbo = TBO(name, UNITS[name] if unit is None else unit, texels, data.nbytes, buf, tex.value,
              internal_format, gl)
    tbo.bind()
    gl.fn("glTexBuffer", None, ctypes.c_uint, ctypes.c_uint, ctypes.c_uint)(
        GL_TEXTURE_BUFFER, internal_format, buf.glo)
    return tbo

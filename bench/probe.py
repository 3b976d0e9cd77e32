"""Run a probe shader over N items and read back one uvec4 per item (the GPU side of the stability
cases in bench/stability/, and of tests that check one GLSL routine at a time).

A probe is a fragment shader of its own that ``#include``\\ s the renderer's GLSL files (so a probe
runs the code that renders) and reads its items from the probe buffer, bound at :data:`PROBE_UNIT`.
It draws a full-screen triangle into an RGBA32UI target of ``width x ceil(N / width)`` pixels;
pixel (x, y) handles item ``y * width + x``. Used to check packed data bit-for-bit and to compare
GPU traversal with numpy references.
"""

from __future__ import annotations

import math
from pathlib import Path

import moderngl
import numpy as np

from mcpt.gpu import shader
from mcpt.gpu.context import GLContext
from mcpt.gpu.tbo import create_tbo

#: The stability suite's probe shaders; a probe named by a bare file name is found here.
PROBE_GLSL = Path(__file__).resolve().parent / "glsl"

#: Texture unit of the probe buffer (``layout(binding = 6)`` in every probe): one that no buffer
#: of the renderer uses (mcpt/gpu/tbo.py UNITS), so a probe can bind those beside it.
PROBE_UNIT = 6


def run_probe(gl: GLContext, fragment: str | Path, probe: np.ndarray, count: int, *,
              preamble: str = "", key=(), tbos: dict | None = None, uniforms: dict | None = None,
              width: int = 256) -> np.ndarray:
    """(count, 4) uint32 written by ``fragment`` (a file name in :data:`PROBE_GLSL`, or the path
    of a probe elsewhere) with ``probe`` bound as the probe buffer and ``tbos`` (name -> array) at
    the renderer's units."""
    ctx = gl.ctx
    path = Path(fragment) if isinstance(fragment, Path) else PROBE_GLSL / fragment
    prog = shader.program(ctx, "fullscreen.vert", path.name, preamble, ("probe", key),
                          fragment_text=path.read_text())
    made = [create_tbo(gl, "probe", probe, unit=PROBE_UNIT)]
    for name, arr in (tbos or {}).items():
        made.append(create_tbo(gl, name, arr))
    height = max(1, math.ceil(count / width))
    tex = ctx.texture((width, height), 4, dtype="u4")
    fbo = ctx.framebuffer(color_attachments=[tex])
    try:
        for t in made:
            t.bind()
        for k, v in {"u_width": width, "u_count": count, **(uniforms or {})}.items():
            if k in prog:
                prog[k].value = v
        fbo.use()
        ctx.disable(moderngl.BLEND)
        vao = ctx.vertex_array(prog, [])
        vao.render(moderngl.TRIANGLES, vertices=3)
        out = np.frombuffer(fbo.read(components=4, dtype="u4"), np.uint32).reshape(-1, 4)[:count]
        vao.release()
        return out.copy()
    finally:
        fbo.release()
        tex.release()
        for t in made:
            t.release()

"""Run a probe shader over N items and read back one uvec4 per item (tests and stability cases of the GPU side).

The probe draws a full-screen triangle into an RGBA32UI target of ``width x ceil(N / width)``
pixels; pixel (x, y) handles item ``y * width + x``. Used to check packed data bit-for-bit and to
compare GPU traversal with numpy references.
"""

from __future__ import annotations

import math
from pathlib import Path

import moderngl
import numpy as np

from mcpt.gpu import shader
from mcpt.gpu.context import GLContext
from mcpt.gpu.tbo import create_tbo

#: The probe shaders (bench/glsl/), found before glsl/ by the shader assembler; they include
#: the renderer's own GLSL files, so a probe tests the code that renders.
PROBE_GLSL = Path(__file__).resolve().parent / "glsl"


def run_probe(gl: GLContext, fragment: str, probe: np.ndarray, count: int, *, preamble: str = "",
              key=(), tbos: dict | None = None, uniforms: dict | None = None,
              width: int = 256) -> np.ndarray:
    """(count, 4) uint32 written by ``fragment`` with ``probe`` bound as the probe buffer."""
    ctx = gl.ctx
    prog = shader.program(ctx, "fullscreen.vert", fragment, preamble, ("probe", key), extra=(PROBE_GLSL,))
    made = [create_tbo(gl, "probe", probe)]
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

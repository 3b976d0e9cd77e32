"""What one dependent texel fetch costs on this GL, by buffer size and buffer kind (issue #23).

The traversal (glsl/bvh.glsl) is a chain of dependent fetches: each step's four texels name the
next record. This tool times that pattern alone: every pixel of a ``--size`` square follows a
random permutation through a buffer of ``--texels`` 16-byte texels for ``--steps`` steps, read
as a texture buffer (``usamplerBuffer``, what mcpt packs) and as a shader storage buffer
(``std430`` ``uvec4[]``), alternating per round in one process. Both sides must end with the
same sums (the check that they read the same data). Nanoseconds per fetch = draw time /
(pixels x steps).

    python -m mcpt.bench.fetch_cost --texels 4096,65536,524288 --rounds 5

Measured (bench/RESULTS.md, stop 35), llvmpipe on the 2-core machine: a texture-buffer fetch
costs ~1.1 ns from 64 KB, ~2.2 ns from 1 MB, ~3 ns from 8 MB and ~20 ns from 64 MB; the storage
buffer costs 13-38 ns (2-12x the texture buffer).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from mcpt.gpu.context import shared_context
from mcpt.gpu.tbo import create_tbo

_VS = "#version 430\nin vec2 p; void main() { gl_Position = vec4(p, 0.0, 1.0); }"
_READ = {
    "tbo": "layout(binding = 1) uniform usamplerBuffer T; uvec4 get(uint i) { return texelFetch(T, int(i)); }",
    "ssbo": "layout(std430, binding = 3) readonly buffer B { uvec4 d[]; }; uvec4 get(uint i) { return d[i]; }",
}


def _fragment(kind: str, texels: int, steps: int) -> str:
    return f"""#version 430
{_READ[kind]}
out uvec4 o;
void main() {{
    uint i = uint(gl_FragCoord.x) * 977u + uint(gl_FragCoord.y) * 131u;
    uvec4 acc = uvec4(0u);
    for (int s = 0; s < {steps}; s++) {{
        uvec4 t = get(i % {texels}u);
        acc += t;
        i = t.x ^ (acc.y & 7u);  // the next address depends on this fetch, as in a traversal
    }}
    o = acc;
}}"""


def measure(texels: int, steps: int = 64, size: int = 512, rounds: int = 5, seed: int = 1) -> dict:
    """Median draw seconds and ns per fetch of each buffer kind for one buffer size."""
    gl = shared_context(None)
    ctx = gl.ctx
    rng = np.random.default_rng(seed)
    data = np.zeros((texels, 4), np.uint32)
    data[:, 0] = rng.permutation(texels)
    data[:, 1:] = rng.integers(0, 1 << 20, (texels, 3))
    tbo = create_tbo(gl, "nodes", data, unit=1)
    ssbo = ctx.buffer(data.tobytes())
    ssbo.bind_to_storage_buffer(3)
    quad = ctx.buffer(np.array([-1, -1, 1, -1, -1, 1, 1, 1], "f4").tobytes())
    target = ctx.framebuffer(color_attachments=[ctx.renderbuffer((size, size), 4, dtype="u4")])
    vaos = {k: ctx.vertex_array(ctx.program(vertex_shader=_VS, fragment_shader=_fragment(k, texels, steps)),
                                [(quad, "2f", "p")]) for k in _READ}
    target.use()
    tbo.bind()
    seconds = {k: [] for k in vaos}
    sums = {}
    for r in range(rounds + 1):  # round 0 warms up (first draws link and fault pages)
        for k in (list(vaos) if r % 2 == 0 else list(vaos)[::-1]):
            ctx.finish()
            t = time.perf_counter()
            vaos[k].render(mode=5)  # TRIANGLE_STRIP
            ctx.finish()
            if r:
                seconds[k].append(time.perf_counter() - t)
            sums[k] = int(np.frombuffer(target.read(components=4, dtype="u4"), np.uint32).astype(np.uint64).sum())
    tbo.release()
    ssbo.release()
    if len(set(sums.values())) != 1:
        raise RuntimeError(f"the buffer kinds read different data: {sums}")
    fetches = size * size * steps
    return {"texels": texels, "bytes": texels * 16, "renderer": gl.renderer,
            **{f"{k}_ns_per_fetch": 1e9 * float(np.median(v)) / fetches for k, v in seconds.items()}}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--texels", default="4096,65536,524288", help="buffer sizes in texels, comma-separated")
    ap.add_argument("--steps", type=int, default=64)
    ap.add_argument("--size", type=int, default=512, help="pixels a side")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    rows = [measure(int(n), a.steps, a.size, a.rounds) for n in a.texels.split(",")]
    if a.json:
        print(json.dumps(rows, indent=1))
        return
    for row in rows:
        print(f"{row['bytes'] / 1024:9.0f} KB  texture buffer {row['tbo_ns_per_fetch']:6.2f} ns/fetch  "
              f"storage buffer {row['ssbo_ns_per_fetch']:6.2f} ns/fetch")


if __name__ == "__main__":
    main()

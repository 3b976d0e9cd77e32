"""The wavefront dispatch (``MCPT_DISPATCH=wavefront``, issue #23; GLSL: glsl/wavefront.glsl).

The path tracer as two compute kernels, shade and trace, run in turn over a rectangle of pixels
until no path is left; between them each bounce's rays are queued in two classes (entering the
dense mesh's box or not) so that a SIMD batch traces rays of like length. Its pixels are the
fragment path's, bit for bit (tests/test_dispatch.py).

Measured on llvmpipe (bench/RESULTS.md): 0.6x the fragment path's paths per CPU-second on the
100k-triangle sphere, because moving a path's state through memory between kernels costs
llvmpipe about what a bounce costs, so it is not the default anywhere. It is here for GPUs, whose
32-lane warps diverge more and whose memory is fast (Laine, Karras & Aila 2013); its speed
there is not measured yet (bench/gpu_peer.py runs it beside the other dispatches).

What it does not do: the AOVs of glsl/aov.glsl and the transparent film (their per-sample state
lives in globals of the fragment path); :func:`unsupported` names them before anything compiles.
"""

from __future__ import annotations

import struct

import moderngl

from . import shader
from .path_state import STATE_IMAGES

#: glsl/wavefront.glsl's work group (1-D) and its storage-buffer bindings; more groups than
#: ROW_GROUPS are laid out in rows (GL guarantees 65535 a dimension; 4096x4096 slots need 262144).
GROUP = 64
ROW_GROUPS = 32768
HITS, TALLY, QUEUE_IN, QUEUE_OUT = 2, 3, 4, 5
_ZERO_COUNTS = bytes(16)


def unsupported(features) -> str | None:
    """What of ``features`` the wavefront dispatch cannot render, or None."""
    if features.options.aov:
        return "the albedo, normal and depth AOVs"
    if features.options.alpha:
        return "a transparent film (render.transparent)"
    return None


def programs(ctx, features) -> list:
    """The shade and the trace kernel (glsl/pathtrace.frag with MCPT_WAVE, WAVE_KERNEL 0 and 1)."""
    return [shader.compute_program(ctx, "pathtrace.frag", f"{features.preamble()}\n#define WAVE_KERNEL {k}",
                                   (features.key, "wave", k))
            for k in (0, 1)]


class Wavefront:
    """The buffers between the kernels, and the loop that runs them over a rectangle."""

    def __init__(self, ctx: moderngl.Context, kernels: list, width: int, height: int):
        self.ctx, (self.shade, self.trace) = ctx, kernels
        slots = width * height
        self.state = [ctx.texture((width, height), 4, dtype="f4") for _ in range(STATE_IMAGES)]
        self.hits = ctx.buffer(reserve=16 * slots)
        self.tally = ctx.buffer(reserve=32 * slots)
        # Two queues, read and written in turn: counts (16 bytes), then two classes of slots.
        self.queues = [ctx.buffer(reserve=16 + 8 * slots) for _ in range(2)]
        self.steps = 0  # kernel pairs run (statistics)

    def bind(self) -> None:
        for i, img in enumerate(self.state):
            img.bind_to_image(i, read=True, write=True)
        self.hits.bind_to_storage_buffer(HITS)
        self.tally.bind_to_storage_buffer(TALLY)

    def draw(self, set_uniform, rect) -> None:
        """Every slot of ``rect`` (x0, y0 in GL rows from the bottom, width, height) through its
        ``u_samples`` samples: shade starts them, then trace and shade alternate until no ray is
        queued. The ray count read back after each shade is what ends the loop."""
        set_uniform("u_dispatch", tuple(rect))
        queued, free = self.queues
        queued.write(_ZERO_COUNTS)  # the first shade reads no queue: an empty one is bound
        set_uniform("u_wave_start", 1)
        self._run(self.shade, rect[2] * rect[3], queued, free)
        set_uniform("u_wave_start", 0)
        queued, free = free, queued
        while n := sum(struct.unpack("<2I", queued.read(8))):
            self._run(self.trace, n, queued, None)
            self._run(self.shade, n, queued, free)
            queued, free = free, queued
            self.steps += 1

    def _run(self, kernel, invocations: int, queued, free) -> None:
        queued.bind_to_storage_buffer(QUEUE_IN)
        if free is not None:
            free.write(_ZERO_COUNTS)
            free.bind_to_storage_buffer(QUEUE_OUT)
        groups = -(-invocations // GROUP)
        kernel.run(min(groups, ROW_GROUPS), -(-groups // ROW_GROUPS))
        self.ctx.memory_barrier()

    def release(self) -> None:
        for obj in self.state + self.queues + [self.hits, self.tally]:
            obj.release()


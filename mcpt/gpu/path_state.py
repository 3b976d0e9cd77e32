"""Paths continued across draws where the driver caps loop iterations (GLSL: glsl/path_state.glsl).

llvmpipe ends a shader invocation's loops after 65535 iterations; a draw therefore follows each
path for a quarter of that, stores the unfinished ones in four RGBA32F images (one texel per
pixel: ray, throughput, radiance so far, bounce index, MIS and roulette state) and counts them in
a 4-byte storage buffer. :meth:`PathState.finish` draws again until the count is zero. Every
draw makes progress (at least one bounce), so at most ``bounces + 1`` draws follow one pass.

Cost: the state is only written for paths still running at the end of a draw, and a pass whose
paths all finished in its first draw (every 8-bounce scene here) only pays for reading the
4-byte count back, which waits for the draw to finish.
"""

from __future__ import annotations

import struct

import moderngl

STATE_IMAGES = 4  # glsl/path_state.glsl u_state0..3


class PathState:
    def __init__(self, ctx: moderngl.Context, width: int, height: int):
        self.ctx = ctx
        self.images = [ctx.texture((width, height), 4, dtype="f4") for _ in range(STATE_IMAGES)]
        for img in self.images:  # no path stored (state 0's w = k = 0)
            img.write(bytes(width * height * 16))
        self.count = ctx.buffer(reserve=4)
        self.draws = 0        # continuation draws made (statistics)
        self.max_draws = 0    # most draws one pass needed

    def bind(self) -> None:
        for i, img in enumerate(self.images):
            img.bind_to_image(i, read=True, write=True)
        self.count.bind_to_storage_buffer(0)

    def reset_count(self) -> None:
        self.count.write(b"\0\0\0\0")

    def unfinished(self) -> int:
        """Paths the last draw stored (waits for it)."""
        self.ctx.memory_barrier()
        return struct.unpack("<I", self.count.read())[0]

    def finish(self, draw, set_continue, limit: int) -> None:
        """After a pass's first draw: ``draw()`` again with ``set_continue(1)`` until no path is left."""
        n, draws = self.unfinished(), 0
        if not n:
            return
        set_continue(1)
        while n and draws < limit:
            self.reset_count()
            draw()
            draws += 1
            n = self.unfinished()
        set_continue(0)
        self.draws += draws
        self.max_draws = max(self.max_draws, draws)

    def release(self) -> None:
        for img in self.images:
            img.release()
        self.count.release()

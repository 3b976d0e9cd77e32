"""Draw copies: small images drawn several times side by side, so that every core gets work
(GLSL side: glsl/draw_copies.frag, and glsl/pathtrace.frag's u_copies).

llvmpipe bins a draw into 64 x 64-pixel tiles and shades each tile on one thread (Mesa
src/gallium/drivers/llvmpipe/lp_limits.h TILE_SIZE, lp_rast.c): a 64 x 64 image is one tile, so
a draw of it runs on one core however many there are (measured on the 2-core machine: 0.37
Mpaths/s at 64 x 64 against 0.82 at 128 x 128, same scene, same paths per draw). With K copies
the path tracer draws a K-times-wider scratch target: copy c takes samples c, c + K, ... of the
draw's samples per pixel (the same sample indices, hence the same random numbers, as one copy
taking them all). After the draw (and its continuation draws, mcpt/gpu/path_state.py) one small
draw adds the copies, in a fixed order, into the image's accumulation targets, so the targets
receive one float32 sum per draw as before and read-backs, checkpoints and farm tasks behave
exactly as without copies (the same numbers in the same order wherever a render starts).

K depends on the image size alone (never on the machine, so that farm workers agree bit for
bit): the smallest power of two giving at least MIN_TILES tiles, at most the draw's samples per
pixel. Images of MIN_TILES tiles or more (128 x 64 and up) draw as before: K = 1, no scratch.
Measured at 64 x 64 under load 9 on the 2 shared cores: K = 2 against K = 1 in one process,
alternating, 1.44x (an env-lit scene) and 1.25x (the Cornell box), K = 4 1.36x and 1.21x (fewer
samples per copy waste more lane time at the end of a draw); mcpt.bench.ab (separate processes)
~1.0x for the Cornell box with K = 2 while other sessions keep both cores busy: the gain is the
second core, there only when it is free.
"""

from __future__ import annotations

import moderngl

from . import shader

TILE = 64       # llvmpipe's tile edge, pixels
MIN_TILES = 2   # tiles a draw should span (2 cores here)
MAX_COPIES = 8  # beyond this the few samples per copy waste path regeneration


def draw_copies(width: int, height: int, samples_per_draw: int, max_size: int = 16384) -> int:
    """Copies for a ``width`` x ``height`` image drawn ``samples_per_draw`` samples at a time."""
    tiles = -(-width // TILE) * -(-height // TILE)
    k = 1
    while tiles * k < MIN_TILES and 2 * k <= min(samples_per_draw, MAX_COPIES) and 2 * k * width <= max_size:
        k *= 2
    return k


class DrawCopies:
    """The scratch targets (``copies`` x the image's width) and the program that adds them up."""

    def __init__(self, ctx: moderngl.Context, width: int, height: int, copies: int, targets: int):
        self.ctx, self.width, self.height, self.copies = ctx, width, height, copies
        self.scratch = [ctx.texture((width * copies, height), 4, dtype="f4") for _ in range(targets)]
        self.fbo = ctx.framebuffer(color_attachments=self.scratch)
        self.program = shader.program(ctx, "fullscreen.vert", "draw_copies.frag",
                                      f"#define COPY_TARGETS {targets}\n", ("draw_copies", targets))
        self.vao = ctx.vertex_array(self.program, [])

    def begin(self) -> None:
        """Before a pass's draws: the scratch targets, cleared, take them."""
        self.fbo.use()
        self.ctx.scissor = (0, 0, self.width * self.copies, self.height)
        self.fbo.clear(0.0, 0.0, 0.0, 0.0)

    def end(self, target: moderngl.Framebuffer) -> None:
        """After them: the copies added into ``target`` (blending ONE, ONE is on)."""
        self.ctx.scissor = None
        target.use()
        self.program["u_width"].value = self.width  # the program is shared by every renderer
        self.program["u_count"].value = self.copies
        for i, t in enumerate(self.scratch):
            t.use(location=12 + i)
        self.vao.render(moderngl.TRIANGLES, vertices=3)

    def release(self) -> None:
        self.vao.release()
        self.fbo.release()
        for t in self.scratch:
            t.release()

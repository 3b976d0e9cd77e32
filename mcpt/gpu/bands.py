"""A draw cut into bands, so that the render loop can stop inside it (issue #24 item 8).

A draw holds up to 2^25 paths (mcpt/gpu/features.py PATHS_PER_DRAW; 2^22, 2.5-6 s on llvmpipe,
when this was written), and a signal or ``--time`` used to wait for the whole of it. Where the render loop may stop
(mcpt/render.py), Renderer.passes draws each draw as several GL draws of at most BAND_PATHS
paths and asks between them whether to go on; a draw cut short is dropped whole (the target
keeps the passes before it), so a stop still falls on the draw grid.

A band changes no pixel: each pixel's samples of a draw are still taken by one shader
invocation with the same numbers (sobol numbers depend on the pixel and the sample index) and
added into the target once. How many bands there are may therefore follow the clock
(Renderer._band_paths) without touching determinism.

A band is a strip of rows (the scissor) of STRIP_PIXELS pixels at least and one of ``parts``
interleaved sets of its 16x16 blocks, drawn as points of size 16 (glsl/fullscreen.vert): llvmpipe
shares a draw among its threads by 64x64 tiles and waits for the last at the end of each, so a
band of 4 tiles (a strip of a 256-wide image) left a thread idle while another finished (bands
x0.90 wall, same CPU, bench/stop_latency.py); parts keep every tile of the strip in every band.
Discarding the pixels of other parts in the fragment shader instead cost 0.27 us a pixel; blocks
as two triangles each cost 26 % more CPU (llvmpipe shades a 4x4 pixel group that a diagonal
crosses once for each triangle).
"""

from __future__ import annotations

#: Paths one band holds at most (0.1-0.35 s on llvmpipe, 2 threads, a shared machine), unless the
#: last draw showed that BAND_SECONDS' worth is more (Renderer._band_paths: a hardware GPU).
BAND_PATHS = 1 << 18
BAND_SECONDS = 0.25
#: Pixels a strip of rows holds at least (16 of llvmpipe's tiles), and the most parts of a strip
#: (glsl/fullscreen.vert: 16 blocks a tile).
STRIP_PIXELS = 1 << 16
MAX_PARTS = 16
TILE = 64  # llvmpipe's tile, in pixels; 4x4 blocks of 16


def plan_bands(tile: tuple, samples: int, band_paths: int) -> list[tuple[int, ...]]:
    """``tile`` (x0, y0, w, h; rows from the top) in bands of at most ``band_paths`` paths
    (``samples`` a pixel) where that can be: ``(x0, y0, w, h, part, parts)``, a strip of rows
    and which of its ``parts`` sets of blocks; the whole tile when ``band_paths`` is 0."""
    x0, y0, w, h = tile
    if not band_paths or w * h * samples <= band_paths:
        return [(x0, y0, w, h, 0, 1)]
    rows = -(-STRIP_PIXELS // w)
    rows = max(16, min(-(-rows // 16) * 16, MAX_PARTS * band_paths // (w * samples) // 16 * 16))
    out = []
    for y in range(y0, y0 + h, rows):
        strip = min(rows, y0 + h - y)
        parts = 1
        while parts < MAX_PARTS and w * strip * samples > parts * band_paths:
            parts *= 2
        out += [(x0, y, w, strip, k, parts) for k in range(parts)]
    return out


def plan_strips(tile: tuple, samples: int, band_paths: int) -> list[tuple[int, ...]]:
    """:func:`plan_bands` for the compute dispatch (glsl/pathtrace.frag MCPT_COMPUTE): strips of
    whole rows of at most ``band_paths`` paths (at least one row), each one rectangle to dispatch;
    the whole tile when ``band_paths`` is 0."""
    x0, y0, w, h = tile
    if not band_paths or w * h * samples <= band_paths:
        return [(x0, y0, w, h, 0, 1)]
    rows = max(1, band_paths // (w * samples))
    return [(x0, y, w, min(rows, y0 + h - y), 0, 1) for y in range(y0, y0 + h, rows)]


def part_geometry(band: tuple, width: int, height: int) -> tuple[tuple[int, int, int, int], int]:
    """glsl/fullscreen.vert's ``u_parts`` and its vertex count for ``band`` (plan_bands) in a
    ``width`` x ``height`` window: a point for each block of the part in all tiles of the tile
    rows the strip crosses (rows from the bottom, as GL counts them); the scissor keeps the
    strip. A whole draw (one part): the triangle that covers the window, 3 vertices."""
    x0, y0, w, h, part, parts = band
    if parts == 1:
        return (0, 1, 0, 1), 3
    first, last = (height - y0 - h) // TILE, (height - y0 - 1) // TILE
    across = -(-width // TILE)
    return (part, parts, first, across), (last - first + 1) * across * (16 // parts)


def padded(width: int, height: int) -> tuple[int, int, int, int]:
    """The viewport of a part's points: the window padded to whole tiles (glsl/fullscreen.vert)."""
    return 0, 0, -(-width // TILE) * TILE, -(-height // TILE) * TILE

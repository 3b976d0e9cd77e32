"""A draw cut into bands, so that the render loop can stop inside it (issue #24 item 8).

A draw holds up to 2^22 paths (mcpt/gpu/features.py PATHS_PER_DRAW), 2.5-6 s on llvmpipe, and a
signal or ``--time`` used to wait for the whole of it. Where the render loop may stop
(mcpt/render.py), Renderer.passes draws each draw as several GL draws, strips of rows of at most
BAND_PATHS paths (the scissor), and asks between them whether to go on; a draw cut short is
dropped whole (the target keeps the passes before it), so a stop still falls on the draw grid.

A band changes no pixel: each pixel's samples of a draw are still taken by one shader
invocation with the same numbers (sobol numbers depend on the pixel and the sample index) and
added into the target once. How many bands there are may therefore follow the clock
(Renderer._band_paths) without touching determinism.

Measured (bench/stop_latency.py): interleaved 16x16 blocks in place of strips, so that every
band spreads over all of llvmpipe's 64x64 tiles, cost 7-10 % more CPU: llvmpipe spends ~0.27 us
a pixel on a fragment that is discarded at once, 1/16 of a 2^18-path band's work per band.
"""

from __future__ import annotations

#: Paths one band holds at most (0.1-0.35 s on llvmpipe, 2 threads, a shared machine), unless the
#: last draw showed that BAND_SECONDS' worth is more (Renderer._band_paths: a hardware GPU).
BAND_PATHS = 1 << 18
BAND_SECONDS = 0.25


def plan_bands(tile: tuple, samples: int, band_paths: int) -> list[tuple[int, int, int, int]]:
    """``tile`` (x0, y0, w, h; rows from the top) as strips of rows of nearly equal height, each
    of at most ``band_paths`` paths (``samples`` a pixel; one row at least); the whole tile when
    ``band_paths`` is 0."""
    x0, y0, w, h = tile
    rows = band_paths // max(1, samples * w) if band_paths else h
    if rows >= h:
        return [(x0, y0, w, h)]
    k = -(-h // max(rows, 1))
    edges = [y0 + h * i // k for i in range(k + 1)]
    return [(x0, a, w, b - a) for a, b in zip(edges, edges[1:])]

"""Passes 0 .. spp-1 of a Renderer added up, for tests that check the image of one compiled
program (mcpt/gpu/render.py) without the render loop's set-up, checkpoints or outputs."""

from __future__ import annotations

import time

from mcpt.farm.accumulate import CHUNK, Accumulator


def render(renderer, spp: int, seed: int, *, chunk: int = CHUNK, samples_per_draw: int | None = None):
    """The RenderResult of ``spp`` passes of ``seed``, summed as the render loop sums them
    (mcpt/render.py). ``samples_per_draw``: another path-regeneration width for this render."""
    keep = renderer.samples_per_draw
    if samples_per_draw is not None:
        renderer.samples_per_draw = samples_per_draw
    try:
        acc = Accumulator.empty(len(renderer.targets), renderer.height, renderer.width, chunk)
        t0 = time.perf_counter()
        for summed, sums in renderer.passes(seed, 0, spp, chunk=chunk):
            acc.add(summed, sums)
        return renderer.result(acc.totals(), spp, seed, time.perf_counter() - t0,
                               renderer.random_seconds)
    finally:
        renderer.samples_per_draw = keep

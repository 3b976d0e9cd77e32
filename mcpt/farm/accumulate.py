"""Adding up pass read-backs so that where a render stops does not change a single bit.

The renderer (mcpt/gpu/render.py, ``Renderer.passes``) blends passes into an RGBA32F target and
reads it back at every multiple of ``chunk`` passes, counted from pass 0. A float64 sum of those
read-backs depends on the ORDER of the additions (floating point is not associative), so this
module keeps one rule: ``complete`` is the float64 sum, in pass order starting from zeros, of the
read-backs of whole chunks; passes after the last whole chunk stay a float32 ``partial`` exactly as
the target held them. Then

* a render that stops early (time budget, signal) and is resumed uploads ``partial`` back into the
  target and carries on: the next read-back is bit-for-bit the one an uninterrupted render makes;
* farm tasks that each render whole chunks return them, and the coordinator adds them in chunk
  order: the same additions as one process;
* the image at any point is ``complete + partial`` (one more addition, as the last, possibly short,
  chunk of an uninterrupted render of that many passes).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CHUNK = 64  # passes per read-back (Renderer.passes' default)


@dataclass
class Accumulator:
    """Sums of passes ``0 .. spp-1`` of one seed: ``complete`` (float64, whole chunks, added in
    order) and ``partial`` (float32 target of the unfinished chunk, or None). ``spp``: the samples
    per pixel summed so far (the render's ``RenderResult.spp`` once it ends)."""

    complete: np.ndarray
    spp: int = 0
    partial: np.ndarray | None = None
    chunk: int = CHUNK

    @classmethod
    def empty(cls, targets: int, height: int, width: int, chunk: int = CHUNK) -> Accumulator:
        return cls(np.zeros((targets, height, width, 4), np.float64), 0, None, chunk)

    @property
    def whole(self) -> int:
        """Passes in ``complete`` (a multiple of ``chunk``)."""
        return self.spp - (self.spp % self.chunk)

    def rewind_to_draw_grid(self, samples_per_draw: int) -> None:
        """Before carrying on from a checkpoint whose last draw ended off the draw grid (a finished
        render of 100 spp drew passes 64..99 in one draw, which a longer render draws as 64..127):
        forget the unfinished chunk and draw it again, so the longer render makes the draws, and
        the sums, of an uninterrupted one (mcpt/gpu/render.py). Costs fewer than ``chunk`` passes.
        A stop on the grid (a time budget or a signal stops after a draw) keeps its ``partial``."""
        if self.partial is not None and self.spp % samples_per_draw:
            self.partial = None
            self.spp = self.whole

    def add(self, spp: int, sums: np.ndarray) -> None:
        """One read-back of ``Renderer.passes``: the passes up to ``spp`` summed."""
        if spp <= self.spp:
            raise ValueError(f"read-back at pass {spp} after pass {self.spp}")
        if self.partial is not None:
            # Renderer.passes continued from ``partial`` (carry), so ``sums`` already holds it.
            self.partial = None
        if spp % self.chunk == 0:
            self.complete += sums
        else:
            self.partial = np.array(sums, np.float32)
        self.spp = spp

    def totals(self) -> np.ndarray:
        """float64 sums of all ``spp`` passes: ``complete`` plus the unfinished chunk."""
        if self.partial is None:
            return self.complete.copy()
        return self.complete + self.partial

"""The plain object-median tree: every node split at the object median of its longest centroid axis.

Used by mcpt/shapes/bvh_build.py above SAH_MAX_TRIANGLES (and with ``sah=False``). A node of c
triangles gets a left child of floor(c / 2) and a right child of ceil(c / 2), and a node splits
while c > max_leaf, so which node has which size is fixed by the triangle count alone (depth
ceil(log2(F / max_leaf)) + 1, the tree shape of the presorted-lists builder this replaces); only
which triangles go where, and each node's axis, depend on the centroids. Every node of level L
holds floor(F / 2^L) or ceil(F / 2^L) triangles (children of sizes {q, q + 1} have sizes
{floor(q / 2), ceil((q + 1) / 2)}, again two neighbours). So a level is held as at most two dense
(rows x width) arrays of triangle ids, one row per node, with the triangles' centroids in arrays
of the same shape; a level takes every row's centroid bounds with row minima and maxima and
splits every row at once with ``np.argpartition(key, width // 2, axis=1)`` (introselect: O(width)
a row, in C) on the centroid of the row's longest axis. That replaces three centroid-sorted id
lists stable-partitioned every level (issue #23, 10^6 triangles: these levels ~0.45-0.6 CPU-s against
~0.9-1.0 for the lists, whose three initial argsorts alone took 0.2 s).

The centroids are rounded to float32 for the splits (half the memory traffic of float64, measured
~25% faster): rounding is monotone, so a split of the rounded keys is still an object median of
the float64 centroids except among centroids that round to the same float32 value (relative
2^-24), which are ties here, and a longest axis may change only between axes of extents equal
to float32 precision. Ties fall where introselect puts them (deterministic: same input, same tree);
on the 10^6-triangle sphere scene 64% of the nodes differ from the old builder's, SAH cost
24.194968 against 24.194978 and a bit-identical image at 32 spp.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..parallel import ordered, workers
from .bvh_flatten import Level

#: Rows narrower than this take their minima and maxima column by column (one vector operation
#: per column over all rows): numpy's reduction along a short contiguous row costs a loop set-up
#: per row, 3-4x slower at width 8 (measured on 2^20 float32 values).
_COLUMN_REDUCE_WIDTH = 16
#: Blocks of fewer triangles split in the calling thread (a thread's hand-off costs more).
_PARALLEL_MIN = 1 << 16


@dataclass
class _Rows:
    """Nodes of one width: ``node`` (r,) their indices in the level; ``ids`` (r, w) int32 triangle
    ids; ``cen`` three (r, w) float32 centroid coordinates of those triangles (none for leaves)."""

    node: np.ndarray
    ids: np.ndarray
    cen: list[np.ndarray]


def median_levels(centroids: np.ndarray, max_leaf: int) -> tuple[list[Level], np.ndarray]:
    """Split nodes level by level down to ``max_leaf`` triangles; returns the levels and the final
    triangle order (int64: reordered triangle j is triangle ``order[j]``).

    ``centroids``: (F, 3) triangle centroids, F >= 1; ``max_leaf`` >= 1.
    """
    n_tris = len(centroids)
    order = np.empty(n_tris, np.int32)
    rows = [_Rows(np.zeros(1, np.int64), np.arange(n_tris, dtype=np.int32)[None],
                  [centroids[:, k].astype(np.float32)[None] for k in range(3)])]
    levels: list[Level] = []
    start = np.zeros(1, np.int64)
    count = np.array([n_tris], np.int64)
    first_id = 0
    while True:
        split = count > max_leaf
        n_split = int(np.count_nonzero(split))
        left = np.full(start.size, -1, np.int64)
        axis = np.full(start.size, -1, np.int64)
        next_id = first_id + start.size
        left[split] = next_id + 2 * np.arange(n_split)
        rank = np.cumsum(split) - 1  # i-th splitting node: children 2i, 2i + 1 of the next level
        splitting = []
        for block in rows:
            w = block.ids.shape[1]
            if w <= max_leaf:  # a leaf: its triangles are final, at the node's start
                at = start[block.node][:, None] + np.arange(w)
                order[at.ravel()] = block.ids.ravel()
            else:
                splitting.append(block)
        dest = _next_rows(splitting, max_leaf)
        filled = dict.fromkeys(dest, 0)
        for block in splitting:
            axis[block.node] = _split_rows(block, rank[block.node], dest, filled)
        levels.append(Level(first_id, start, count, left, axis))
        if n_split == 0:
            break
        rows = list(dest.values())
        s, c = start[split], count[split]
        count = np.stack([c // 2, c - c // 2], axis=1).ravel()
        start = np.stack([s, s + c // 2], axis=1).ravel()
        first_id = next_id
    return levels, order.astype(np.int64)


def _next_rows(splitting: list[_Rows], max_leaf: int) -> dict[int, _Rows]:
    """Empty blocks for the children of ``splitting``'s rows, by width (two widths: see the
    module docstring); leaves get no centroid arrays."""
    total: dict[int, int] = {}
    for block in splitting:
        r, w = block.ids.shape
        for width in (w // 2, w - w // 2):
            total[width] = total.get(width, 0) + r
    return {w: _Rows(np.empty(n, np.int64), np.empty((n, w), np.int32),
                     [np.empty((n, w), np.float32) for _ in range(3)] if w > max_leaf else [])
            for w, n in total.items()}


def _split_rows(block: _Rows, rank: np.ndarray, dest: dict[int, _Rows], filled: dict[int, int]) -> np.ndarray:
    """Split every row of ``block`` at the object median of its longest centroid axis, the halves
    taken straight into their rows of ``dest``; return the rows' axes. Rows are independent and
    their destinations fixed here, so chunks of rows run on every core (mcpt/parallel.py) and
    give the same tree as one pass over all of them."""
    r, w = block.ids.shape
    h = w // 2
    kids = 2 * rank
    # Destinations first: (width, offset of the chunk's first row there, rows per block row).
    if 2 * h == w:
        # Both halves h wide: row i of the permuted block is rows 2i, 2i + 1 of the children's.
        outs = [(h, filled[h], 2, slice(0, w))]
        dest[h].node[filled[h]:filled[h] + 2 * r] = (kids[:, None] + np.arange(2)).ravel()
        filled[h] += 2 * r
    else:
        outs = []
        for node, cols in ((kids, slice(0, h)), (kids + 1, slice(h, w))):
            width = cols.stop - cols.start
            outs.append((width, filled[width], 1, cols))
            dest[width].node[filled[width]:filled[width] + r] = node
            filled[width] += r
    n_chunks = min(workers(), r) if r * w >= _PARALLEL_MIN else 1
    cut = [r * c // n_chunks for c in range(n_chunks + 1)]

    def chunk(c: int) -> np.ndarray:
        a, b = cut[c], cut[c + 1]
        rows = slice(a, b)
        extent = np.stack([_row_max(x[rows]) - _row_min(x[rows]) for x in block.cen], axis=1)
        row_axis = np.argmax(extent, axis=1)  # all-equal centroids: axis 0, split by position
        k0 = int(row_axis[0])
        if (row_axis == k0).all():
            key = block.cen[k0][rows]
        else:
            # Row by row from the axis's array: each value is read once (a where-chain reads two).
            key = np.empty((b - a, w), np.float32)
            for k in range(3):
                sel = np.flatnonzero(row_axis == k)
                key[sel] = block.cen[k][a + sel]
        # The h smallest keys of each row before position h, the others from h on: an object median.
        perm = np.argpartition(key, h, axis=1)
        perm += (np.arange(a, b, dtype=np.int64) * w)[:, None]
        for width, o, per, cols in outs:
            part = perm if per == 2 else np.ascontiguousarray(perm[:, cols])
            _take_rows(block, part, dest[width], o + per * a, per * (b - a), (b - a, cols.stop - cols.start))
        return row_axis

    return np.concatenate(ordered(chunk, range(n_chunks)))


def _take_rows(block: _Rows, index: np.ndarray, d: _Rows, o: int, n: int, shape: tuple[int, int]) -> None:
    """Rows ``o .. o + n`` of ``d`` (viewed as ``shape``) from ``block`` at the flat ``index``.

    A 1-D take, several times faster than take_along_axis, written straight into the next level's
    block (no halves joined afterwards: ~10% of these levels). mode="clip" because numpy buffers
    ``out`` under the default mode="raise"; the indices are valid. Leaves (``d.cen`` empty) get no
    centroids."""
    np.take(block.ids.ravel(), index, out=d.ids[o:o + n].reshape(shape), mode="clip")
    for c, dc in zip(block.cen, d.cen):
        np.take(c.ravel(), index, out=dc[o:o + n].reshape(shape), mode="clip")


def _row_max(a: np.ndarray) -> np.ndarray:
    return _row_reduce(a, np.maximum)


def _row_min(a: np.ndarray) -> np.ndarray:
    return _row_reduce(a, np.minimum)


def _row_reduce(a: np.ndarray, op: np.ufunc) -> np.ndarray:
    """``op`` (np.minimum or np.maximum) over every row of ``a``: column by column for narrow rows."""
    if a.shape[1] >= _COLUMN_REDUCE_WIDTH:
        return op.reduce(a, axis=1)
    out = a[:, 0].copy()
    for j in range(1, a.shape[1]):
        op(out, a[:, j], out=out)
    return out

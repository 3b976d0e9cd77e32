"""Packing a BVH built level by level into the node layout of mcpt/shapes/bvh.py.

Both builders (the SAH-chosen median tree of mcpt/shapes/bvh_build.py, the plain median tree of
mcpt/shapes/bvh_median.py) describe their tree as `Level` records, level by level; `flatten`
computes every node's box (leaves from their triangles' boxes, then bottom-up), numbers the nodes
in depth-first pre-order and packs them as (M, 8) uint32. Boxes are float32 throughout: the
leaves' are rounded outward once, and a parent's is a min/max of float32 values, exact in float32.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..parallel import ordered
from .bvh import LEAF_FLAG
from .rows import put_rows


@dataclass
class Level:
    """Nodes of one tree level; node ids are `first_id + arange(len(start))`. The children of the
    level's i-th splitting node are the next level's nodes 2i (left) and 2i + 1 (right)."""

    first_id: int
    start: np.ndarray  # first position of the node's triangles in the final order
    count: np.ndarray  # number of triangles
    left: np.ndarray  # id of the left child (right = left + 1), -1 for a leaf
    axis: np.ndarray  # split axis, -1 for a leaf


def _round_out(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Round float64 box corners outward to float32 values; float32 ones are already exact."""
    if lo.dtype == np.float32 and hi.dtype == np.float32:
        return lo, hi
    lo32 = lo.astype(np.float32)
    hi32 = hi.astype(np.float32)
    lo32 = np.where(lo32.astype(np.float64) > lo, np.nextafter(lo32, np.float32(-np.inf)), lo32)
    hi32 = np.where(hi32.astype(np.float64) < hi, np.nextafter(hi32, np.float32(np.inf)), hi32)
    return lo32, hi32


def flatten(levels: list[Level], order: np.ndarray, tri_lo: np.ndarray, tri_hi: np.ndarray) -> np.ndarray:
    """Compute boxes bottom-up, renumber depth-first pre-order, pack (M, 8) uint32.

    ``tri_lo``, ``tri_hi``: (F, 3) triangle box corners (float32, or float64 rounded out here)."""
    start = np.concatenate([lv.start for lv in levels])
    count = np.concatenate([lv.count for lv in levels])
    left = np.concatenate([lv.left for lv in levels])
    axis = np.concatenate([lv.axis for lv in levels])
    n_nodes = start.size
    leaf = left < 0

    # Leaf boxes: leaves partition [0, F) of the final order, so one reduceat does them all.
    # Their starts are distinct (no leaf is empty): sorted by one scatter into [0, F), several
    # times faster than an argsort of the starts.
    by_start = np.full(len(order), -1, np.int64)
    by_start[start[leaf]] = np.flatnonzero(leaf)
    leaf_ids = by_start[by_start >= 0]
    leaf_start = start[leaf_ids]
    # All boxes in float32: children's are float32 values, so their min/max are exact in it.
    lo = np.empty((n_nodes, 3), np.float32)
    hi = np.empty((n_nodes, 3), np.float32)

    def axis_bounds(k):  # the axes on every core
        # One contiguous column at a time: gathering and reducing 1-D columns is ~2x faster than
        # rows of an (F, 3) array, with the same values.
        return _round_out(np.minimum.reduceat(np.ascontiguousarray(tri_lo[:, k]).take(order), leaf_start),
                          np.maximum.reduceat(np.ascontiguousarray(tri_hi[:, k]).take(order), leaf_start))

    for k, (lo_k, hi_k) in enumerate(ordered(axis_bounds, range(3))):
        lo[leaf_ids, k], hi[leaf_ids, k] = lo_k, hi_k

    # Interior boxes and subtree sizes bottom-up. The i-th interior node of a level has the next
    # level's nodes 2i and 2i + 1 as children (both builders number them so), so the children are
    # strided slices of the next level, not gathers.
    interior = [lv.first_id + np.flatnonzero(lv.left >= 0) for lv in levels]  # per level
    subtree = np.ones(n_nodes, np.int64)
    for ids in reversed(interior):
        if ids.size == 0:
            continue
        kids = slice(int(left[ids[0]]), int(left[ids[-1]]) + 2, 2)
        rights = slice(kids.start + 1, kids.stop, 2)
        lo[ids] = np.minimum(lo[kids], lo[rights])
        hi[ids] = np.maximum(hi[kids], hi[rights])
        subtree[ids] = 1 + subtree[kids] + subtree[rights]

    # Depth-first pre-order: left child right after its parent, right child after the whole
    # left subtree. Lets the shader skip storing the left index.
    pre = np.zeros(n_nodes, np.int64)
    for ids in interior:
        lc = left[ids]
        pre[lc] = pre[ids] + 1
        pre[lc + 1] = pre[ids] + 1 + subtree[lc]

    right = np.where(leaf, 0, left + 1)  # 0: placeholder index for leaves, masked below
    # Packed in node-id order, then moved to pre-order as whole 32-byte rows in one scatter.
    packed = np.empty((n_nodes, 8), np.uint32)
    packed[:, 0:3] = lo.view(np.uint32)
    packed[:, 3] = np.where(leaf, start, pre[right])
    packed[:, 4:7] = hi.view(np.uint32)
    packed[:, 7] = np.where(leaf, count | LEAF_FLAG, axis)
    nodes = np.empty_like(packed)
    put_rows(nodes, pre, packed)  # whole 32-byte rows (mcpt/shapes/rows.py)
    return nodes

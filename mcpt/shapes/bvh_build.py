"""Building the BVH: median splits over triangles, the axis and the leaves chosen by SAH.

Build: object-median splits. Each node is split at the object median of one axis, the axis
chosen among the three by the surface area heuristic (SAH: MacDonald & Booth 1990), and a node
of at most ``max_leaf`` triangles stays a leaf where SAH prices the leaf no dearer than its best
split; SAH prices are loop iterations of glsl/bvh.glsl, where a node step and a triangle test
cost the same (SAH_STEP_COST, SAH_TRI_COST). Above SAH_MAX_TRIANGLES, or with ``sah=False``,
the longest axis of the centroid bounds is split down to ``max_leaf`` (the build's cost), by
mcpt/shapes/bvh_median.py (rows of ids split by argpartition). The tree is built level by level
with every node of a level handled by the same numpy operations, so the Python work is O(depth),
not O(triangles) or O(nodes). The SAH path keeps three index lists, each sorted by one
centroid axis, grouped by node and sorted inside every node; splitting a node at its
median on axis k is then "the first half of list k goes left", and all three lists are
stable-partitioned once per level (the classic presorted kd-tree build). A node that becomes a
leaf leaves the lists, so each level costs O(triangles still being split).
Leaves hold at most `max_leaf` triangles; nodes whose centroids all coincide are still split
in half by position, so depth is at most ceil(log2(F)) + 1 for any input (ceil(log2(F /
max_leaf)) + 1 without SAH). The GPU buffer (BVH.gpu_nodes) is a different, traversal-shaped
layout of the same tree.

Large triangles get their own subtree: a pure object-median split mixes the few big triangles of
a scene (room walls) into leaves of small ones (a bunny), and each such leaf's box -- and every
ancestor's -- grows to room size, so every ray visits those paths. Triangles whose box diagonal is
more than LARGE_TRIANGLE_FACTOR times the median go into a second median-split tree under a
common root (measured: the bunny in the Cornell box renders 5x faster, same image). Depth grows
by one at most.
"""

from __future__ import annotations

import time

import numpy as np

from ..parallel import ordered, row_chunks
from .bvh import BVH, DEFAULT_MAX_LEAF, LEAF_FLAG, MAX_STACK, SAH_MAX_TRIANGLES, SAH_STEP_COST, SAH_TRI_COST
from .bvh_flatten import Level, flatten
from .bvh_median import median_levels
from .rows import take_rows

#: A triangle whose box diagonal exceeds this multiple of the median goes to the large subtree.
LARGE_TRIANGLE_FACTOR = 8.0


def build_bvh(tri_vertices: np.ndarray, max_leaf: int = DEFAULT_MAX_LEAF, sah: bool = True) -> BVH:
    """Build a median-split BVH over triangles, large triangles in their own subtree.

    Same arguments, result and errors as :func:`build_median_bvh`.
    """
    t_start = time.perf_counter()
    tris, max_leaf = _checked(tri_vertices, max_leaf)
    lo, hi, centroids, diag = _boxes(tris)
    if len(tris) > 2 * max_leaf:
        large = diag > LARGE_TRIANGLE_FACTOR * np.median(diag)
        if large.any() and not large.all():
            # The subtrees need only the triangles' centroids and boxes: no (F, 3, 3) copy.
            small_ids, large_ids = np.flatnonzero(~large), np.flatnonzero(large)
            joined = _join(_median_tree(*(take_rows(a, small_ids) for a in (centroids, lo, hi)), max_leaf, sah),
                           small_ids,
                           _median_tree(*(take_rows(a, large_ids) for a in (centroids, lo, hi)), max_leaf, sah),
                           large_ids)
            return BVH(joined.nodes, joined.order, joined.depth, max_leaf,
                       time.perf_counter() - t_start)
    bvh = _median_tree(centroids, lo, hi, max_leaf, sah)
    return BVH(bvh.nodes, bvh.order, bvh.depth, max_leaf, time.perf_counter() - t_start)


def _join(a: BVH, a_ids: np.ndarray, b: BVH, b_ids: np.ndarray) -> BVH:
    """One tree with ``a`` (over original triangles ``a_ids``) left and ``b`` right of a new root."""
    na = len(a.nodes)
    nodes = np.zeros((1 + na + len(b.nodes), 8), np.uint32)
    left, right = a.nodes.copy(), b.nodes.copy()
    left[~a.is_leaf, 3] += 1                 # right-child indices move down by the new root
    right[~b.is_leaf, 3] += 1 + na
    right[b.is_leaf, 3] += len(a_ids)        # b's triangles follow a's in the new order
    nodes[1:1 + na], nodes[1 + na:] = left, right
    nodes[0, 0:3] = np.minimum(a.bounds_min[0], b.bounds_min[0]).view(np.uint32)
    nodes[0, 4:7] = np.maximum(a.bounds_max[0], b.bounds_max[0]).view(np.uint32)
    nodes[0, 3] = 1 + na                     # right child; left child is node 1
    extent = a.bounds_max[0].astype(np.float64) - a.bounds_min[0]
    nodes[0, 7] = int(np.argmax(extent))     # split axis: any is valid for traversal order
    order = np.concatenate([a_ids[a.order], b_ids[b.order]]).astype(np.int64)
    depth = 1 + max(a.depth, b.depth)
    if depth + 2 > MAX_STACK:
        raise RuntimeError(f"BVH depth {depth} needs a traversal stack larger than MAX_STACK={MAX_STACK}")
    return BVH(nodes, order, depth, a.max_leaf, a.build_seconds + b.build_seconds)


def build_median_bvh(tri_vertices: np.ndarray, max_leaf: int = DEFAULT_MAX_LEAF, sah: bool = True) -> BVH:
    """Build a pure median-split BVH over triangles.

    Args:
        tri_vertices: (F, 3, 3) corner positions (triangle, corner, xyz) in scene units,
            float32 or float64; must be finite. F = 0 gives a single empty leaf that no ray hits.
        max_leaf: maximum triangles per leaf (>= 1).
        sah: choose each node's split among the three axes' object medians by SAH, and keep
            nodes of up to ``max_leaf`` triangles as leaves only where SAH says a leaf is
            cheaper (leaves may then be smaller than the cap). False, or more than
            SAH_MAX_TRIANGLES triangles: the longest centroid axis's median, split down to
            ``max_leaf``.

    Returns:
        The flattened `BVH` (see the module docstring for the node layout).

    Raises:
        ValueError: bad shape, non-finite coordinates, max_leaf < 1, or F >= 2^31.
        RuntimeError: the tree would be deeper than the GPU stack allows (`MAX_STACK`).
    """
    t_start = time.perf_counter()
    tris, max_leaf = _checked(tri_vertices, max_leaf)
    bvh = _median_tree(_centroids(tris), *_corner_bounds(tris), max_leaf, sah)
    return BVH(bvh.nodes, bvh.order, bvh.depth, max_leaf, time.perf_counter() - t_start)


def _checked(tri_vertices: np.ndarray, max_leaf: int) -> tuple[np.ndarray, int]:
    """The triangles as a float32 or float64 (F, 3, 3) array and ``max_leaf`` as an int, or the
    ValueError of :func:`build_median_bvh`."""
    tris = np.asarray(tri_vertices)
    if tris.ndim != 3 or tris.shape[1:] != (3, 3):
        raise ValueError(f"tri_vertices must have shape (F, 3, 3), got {tris.shape}")
    if not 1 <= int(max_leaf) < LEAF_FLAG:
        raise ValueError(f"max_leaf must be in [1, 2^31), got {max_leaf}")
    if tris.shape[0] >= LEAF_FLAG:
        raise ValueError(f"{tris.shape[0]} triangles do not fit the 31-bit leaf fields")
    if tris.dtype != np.float32:
        # float32 input stays float32: every box is a min/max of its values (exact in either
        # type) and the centroids are summed in float64 below, so the tree is the same, and no
        # (F, 3, 3) float64 copy is made (72 MB at 10^6 triangles, issue #23).
        tris = tris.astype(np.float64, copy=False)
    if not np.isfinite(tris).all():
        bad = int((~np.isfinite(tris).all(axis=(1, 2))).sum())
        raise ValueError(f"{bad} triangles have non-finite coordinates")
    return tris, int(max_leaf)


def _boxes(tris: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(lo, hi, centroids, diag): every triangle's box corners (`_corner_bounds`), centroid
    (`_centroids`) and box diagonal (float64). Row by row, so the rows are cut into one chunk per
    core (issue #23: 0.2 s in one thread at 10^6 triangles), each written in place."""
    n = len(tris)
    lo, hi = np.empty((n, 3), tris.dtype), np.empty((n, 3), tris.dtype)
    centroids, diag = np.empty((n, 3)), np.empty(n)

    def fill(rows: slice) -> None:
        # _corner_bounds and _centroids, the same operations in the same order, written in place.
        t, lo_r, hi_r, c = tris[rows], lo[rows], hi[rows], centroids[rows]
        np.minimum(np.minimum(t[:, 0], t[:, 1], out=lo_r), t[:, 2], out=lo_r)
        np.maximum(np.maximum(t[:, 0], t[:, 1], out=hi_r), t[:, 2], out=hi_r)
        c[...] = t[:, 0]
        c += t[:, 1]
        c += t[:, 2]
        c /= 3.0
        # |hi - lo| summed by hand: the same values as np.linalg.norm(axis=1) (x0^2 + x1^2 + x2^2
        # in that order), ~3x faster than its reduction over rows of 3.
        d = hi_r.astype(np.float64)
        d -= lo_r
        d *= d
        np.sqrt(d[:, 0] + d[:, 1] + d[:, 2], out=diag[rows])

    ordered(fill, row_chunks(n))
    return lo, hi, centroids, diag


def _corner_bounds(tris: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(F, 3) per-triangle box corners, in the input's type. Corner-wise minimum/maximum: the
    same values as min/max(axis=1), 10x faster on (F, 3, 3)."""
    lo = np.minimum(np.minimum(tris[:, 0], tris[:, 1]), tris[:, 2])
    hi = np.maximum(np.maximum(tris[:, 0], tris[:, 1]), tris[:, 2])
    return lo, hi


def _centroids(tris: np.ndarray) -> np.ndarray:
    """(F, 3) triangle centroids, summed in float64 whatever the input type; 4x faster than
    mean(axis=1)."""
    return (tris[:, 0].astype(np.float64) + tris[:, 1] + tris[:, 2]) / 3.0


def _median_tree(centroids: np.ndarray, lo: np.ndarray, hi: np.ndarray, max_leaf: int, sah: bool) -> BVH:
    """:func:`build_median_bvh` on checked input, given its triangles' centroids (`_centroids`)
    and boxes (`_corner_bounds`)."""
    n_tris = centroids.shape[0]
    if n_tris == 0:
        # Inverted box (+inf, -inf): every slab test misses, so an empty scene renders black.
        nodes = np.zeros((1, 8), np.uint32)
        nodes[0, 0:3] = np.full(3, np.inf, np.float32).view(np.uint32)
        nodes[0, 4:7] = np.full(3, -np.inf, np.float32).view(np.uint32)
        nodes[0, 7] = LEAF_FLAG
        return BVH(nodes, np.zeros(0, np.int64), 1, max_leaf, 0.0)

    if sah and n_tris <= SAH_MAX_TRIANGLES:
        boxes = np.empty((6, n_tris), np.float32)   # (lo, -hi) per column: mins only
        boxes[:3] = lo.T
        boxes[3:] = -hi.T
        levels, order = _split_levels(centroids, boxes, max_leaf)
    else:
        levels, order = median_levels(centroids, max_leaf)
    nodes = flatten(levels, order, lo, hi)
    depth = len(levels)
    if depth + 2 > MAX_STACK:
        raise RuntimeError(f"BVH depth {depth} needs a traversal stack larger than MAX_STACK={MAX_STACK}")
    return BVH(nodes, order, depth, max_leaf, 0.0)


# --------------------------------------------------------------------------------------------
# build internals


class _Lists:
    """The triangles still being split, as three id lists (one per centroid axis), grouped by node
    in order of their start and sorted by centroid k inside each node; and the final ``order``
    that nodes becoming leaves write their triangles to.

    numpy's default sort is deterministic (same input, same order of ties) and 4x faster than its
    stable sort. int32 halves the memory traffic. A node that becomes a leaf writes its triangles
    to ``order`` and leaves the lists, so every per-level operation runs over the triangles still
    being split, contiguously."""

    def __init__(self, centroids: np.ndarray, boxes: np.ndarray):
        n_tris = len(centroids)
        self.ids = np.stack(ordered(lambda k: np.argsort(centroids[:, k]).astype(np.int32), range(3)))
        self.order = np.empty(n_tris, np.int32)
        self.goes_right = np.zeros(n_tris, dtype=bool)  # scratch, only read where just written
        # The boxes in each list's order, (3, 6, F), moved along with the lists, so a node's
        # boxes are a contiguous slice instead of a random gather by triangle id.
        self.boxes = np.stack([boxes[:, self.ids[k]] for k in range(3)])

    def drop(self, keep_nodes, s, c, off) -> None:
        """Write the triangles of nodes not in ``keep_nodes`` to `order`; keep the others."""
        keep = np.repeat(keep_nodes, c)
        gone = ~keep
        gpos = np.repeat((s - off).astype(np.int32), c)[gone]
        gpos += np.flatnonzero(gone).astype(np.int32)
        self.order[gpos] = self.ids[0][gone]
        self.ids = self.ids[:, keep]
        self.boxes = self.boxes[:, :, keep]

    def partition(self, node_axis, c, n_split) -> np.ndarray:
        """Split every node at its object median on ``node_axis``; returns the child sizes, left
        then right per node."""
        lists = self.ids
        # `right_half` marks list positions in a right child.
        child_count = np.stack([c // 2, c - c // 2], axis=1).ravel()
        right_half = np.repeat(np.tile(np.array([False, True]), n_split), child_count)
        # Side of every triangle: the upper half of its node's list on the node's split axis.
        k0 = int(node_axis[0])
        if (node_axis == k0).all():
            on_axis = lists[k0]
        else:
            pos_axis = np.repeat(node_axis.astype(np.int8), c)
            on_axis = np.where(pos_axis == 0, lists[0], np.where(pos_axis == 1, lists[1], lists[2]))
        self.goes_right[on_axis] = right_half

        # Stable partition of every list inside every node: left triangles keep their order
        # from the node start, right ones from the median. A list on its node's own split axis
        # is already partitioned, so the list all nodes split on does not move.
        # The sides read back are random within a node: select through flatnonzero (branch-free)
        # rather than a boolean mask, 5x faster; the halves' masks are runs, cheap to assign.
        left_half = ~right_half

        def move(k):  # list k's partition; the lists move independently, on every core
            ids = lists[k]
            r = self.goes_right[ids]
            to_left, to_right = np.flatnonzero(~r), np.flatnonzero(r)
            new = np.empty_like(ids)
            new[left_half] = ids[to_left]
            new[right_half] = ids[to_right]
            b = self.boxes[k]
            nb = np.empty_like(b)
            nb[:, left_half] = np.take(b, to_left, axis=1)
            nb[:, right_half] = np.take(b, to_right, axis=1)
            return new, nb

        moving = [k for k in range(3) if not (node_axis == k).all()]
        for k, (new, nb) in zip(moving, ordered(move, moving)):
            lists[k] = new
            self.boxes[k] = nb
        return child_count


def _split_levels(centroids: np.ndarray, boxes: np.ndarray, max_leaf: int) -> tuple[list[Level], np.ndarray]:
    """Split nodes level by level, SAH choosing; returns the levels and the final triangle order.

    ``boxes`` (6, F) float32 triangle boxes as (lo, -hi). The three axes' object medians are
    scored by SAH and the cheapest taken; a node of at most ``max_leaf`` triangles stays a leaf
    when SAH prices the leaf at most at its best split. Larger nodes always split, so leaves
    respect the cap. (The plain median tree: mcpt/shapes/bvh_median.py.)
    """
    lists = _Lists(centroids, boxes)
    levels: list[Level] = []
    start = np.zeros(1, np.int64)
    count = np.array([len(centroids)], np.int64)
    first_id = 0
    while start.size:
        off = np.cumsum(count) - count  # where each node starts inside the lists
        split = count > 1
        if not split.all():
            lists.drop(split, start, count, off)
        s, c = start[split], count[split]
        n_split = s.size
        if n_split == 0:
            levels.append(Level(first_id, start, count, np.full(start.size, -1, np.int64),
                                 np.full(start.size, -1, np.int64)))
            break
        seg_offset = np.cumsum(c) - c  # where each splitting node starts inside the lists
        node_axis, keep_leaf = _sah_choice(lists.boxes, seg_offset, c, max_leaf)
        if keep_leaf.any():
            # Nodes SAH keeps as leaves drop out of this level's split.
            idx = np.flatnonzero(split)
            split[idx[keep_leaf]] = False
            go = ~keep_leaf
            lists.drop(go, s, c, seg_offset)
            s, c, node_axis = s[go], c[go], node_axis[go]
            n_split = s.size
        mid = s + c // 2  # object median: the left child gets floor(c / 2) triangles
        next_id = first_id + start.size
        left = np.full(start.size, -1, np.int64)
        left[split] = next_id + 2 * np.arange(n_split)
        axis = np.full(start.size, -1, np.int64)
        axis[split] = node_axis
        levels.append(Level(first_id, start, count, left, axis))
        if n_split == 0:
            break
        count = lists.partition(node_axis, c, n_split)
        start = np.stack([s, mid], axis=1).ravel()
        first_id = next_id
    return levels, lists.order.astype(np.int64)


def _half_areas(m: np.ndarray) -> np.ndarray:
    """Half surface areas of (n, 6) boxes stored as (lo, -hi)."""
    e = np.maximum(-m[:, 3:] - m[:, :3], 0.0)
    return e[:, 0] * e[:, 1] + e[:, 1] * e[:, 2] + e[:, 2] * e[:, 0]


def _sah_choice(node_boxes, seg_offset, c, max_leaf):
    """SAH cost of each splitting node's three object-median splits (Goldsmith & Salmon 1987,
    MacDonald & Booth 1990): C_STEP + (A_L n_L + A_R n_R) / A C_TRI, children priced as leaves.
    Returns the cheapest axis per node and which nodes (count <= max_leaf) SAH keeps as leaves.

    ``node_boxes[k]``: (6, P) boxes of the splitting nodes' triangles in list-k order, node after
    node; the left half of node i on axis k is columns ``seg_offset[i] .. + c[i] // 2``."""
    n_left = c // 2
    n_right = c - n_left
    bounds = np.stack([seg_offset, seg_offset + n_left], axis=1).ravel()
    cost = np.empty((3, c.size))
    parent = None
    for k in range(3):
        b = np.minimum.reduceat(node_boxes[k], bounds, axis=1).T  # (2n, 6): left, right boxes
        a = _half_areas(b).reshape(-1, 2)
        if parent is None:
            parent = _half_areas(np.minimum(b[0::2], b[1::2]))
        cost[k] = a[:, 0] * n_left + a[:, 1] * n_right
    node_axis = np.argmin(cost, axis=0)
    best = cost[node_axis, np.arange(c.size)]
    flat = parent <= 0.0   # a point or a segment: any split, never a forced leaf
    split_cost = SAH_STEP_COST + best / np.where(flat, 1.0, parent) * SAH_TRI_COST
    keep_leaf = (c <= max_leaf) & (c * SAH_TRI_COST <= split_cost) & ~flat
    return node_axis, keep_leaf

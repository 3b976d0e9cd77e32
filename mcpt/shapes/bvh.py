"""Median-split bounding volume hierarchy over triangles, flattened for the GPU.

Build: object-median split along the longest axis of each node's centroid bounds. The tree is
built level by level with every node of a level handled by the same numpy operations, so the
Python work is O(depth), not O(triangles) or O(nodes): three index lists, each sorted by one
centroid axis, are kept grouped by node and sorted inside every node; splitting a node at its
median on axis k is then "the first half of list k goes left", and all three lists are
stable-partitioned with one cumulative sum per level (the classic presorted kd-tree build).
Leaves hold at most `max_leaf` triangles; nodes whose centroids all coincide are still split
in half by position, so depth is at most ceil(log2(F / max_leaf)) + 1 for any input.

Large triangles get their own subtree: a pure object-median split mixes the few big triangles of
a scene (room walls) into leaves of small ones (a bunny), and each such leaf's box -- and every
ancestor's -- grows to room size, so every ray visits those paths. Triangles whose box diagonal is
more than LARGE_TRIANGLE_FACTOR times the median go into a second median-split tree under a
common root (measured: the bunny in the Cornell box renders 5x faster, same image). Depth grows
by one at most.

GPU layout (`BVH.nodes`, (M, 8) uint32, row-major; upload with `nodes.tobytes()` into an
RGBA32UI texture buffer, node i = texels 2i and 2i+1, read floats with uintBitsToFloat)::

    texel 2i   = (bmin.x, bmin.y, bmin.z, a)      bmin/bmax: float32 bit patterns
    texel 2i+1 = (bmax.x, bmax.y, bmax.z, b)
    leaf:      a = first triangle (index into the REORDERED triangles), b = count | 0x80000000
    interior:  left child = i + 1 (depth-first pre-order), a = right child index,
               b = split axis (0 = x, 1 = y, 2 = z); b < 0x80000000 tells it is interior
    node 0 is the root.

Reordered triangle j is original triangle `order[j]`: upload `tris[bvh.order]` (and reorder
any per-triangle data, e.g. material ids, the same way).

Boxes are computed in float64 and rounded outward to float32, so each float32 box contains
the float32 vertices of its triangles, and a parent box contains its children's boxes exactly.
A traversal still needs a conservative slab test (pad tmax by a few ulps) to never miss a
hit whose point lies on a box face, e.g. axis-aligned walls whose boxes are flat.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

__all__ = [
    "BVH",
    "LEAF_FLAG",
    "MAX_STACK",
    "build_bvh",
]

#: Size of the per-ray traversal stack in the GLSL shader (entries of node indices). The stack
#: holds at most one deferred (far) child per level, so depth + 2 entries are always enough;
#: `build_bvh` refuses trees that would overflow it (median splits reach depth 62 only at
#: 2^60 triangles, so this never fires in practice).
MAX_STACK = 64

#: Top bit of texel1.w marks a leaf; the remaining 31 bits hold the triangle count.
LEAF_FLAG = 0x80000000
#: Triangles per leaf the GPU traversal handles (glsl/bvh.glsl BVH_MAX_LEAF, unrolled there).
GPU_MAX_LEAF = 4


@dataclass(frozen=True, eq=False)
class BVH:
    """A flattened BVH; arrays are read-only.

    Attributes:
        nodes: (M, 8) uint32 node records, layout in the module docstring.
        order: (F,) int64 triangle permutation: reordered triangle j is original `order[j]`.
        depth: nodes on the longest root-to-leaf path (a lone root leaf has depth 1).
        max_leaf: the leaf-size limit the tree was built with.
        build_seconds: wall-clock build time in seconds.
    """

    nodes: np.ndarray
    order: np.ndarray
    depth: int
    max_leaf: int
    build_seconds: float

    def __post_init__(self) -> None:
        self.nodes.flags.writeable = False
        self.order.flags.writeable = False

    @property
    def num_nodes(self) -> int:
        return int(self.nodes.shape[0])

    @property
    def num_triangles(self) -> int:
        return int(self.order.shape[0])

    @property
    def bounds_min(self) -> np.ndarray:
        """(M, 3) float32 lower box corners (a view of `nodes`)."""
        return self.nodes[:, 0:3].view(np.float32)

    @property
    def bounds_max(self) -> np.ndarray:
        """(M, 3) float32 upper box corners (a view of `nodes`)."""
        return self.nodes[:, 4:7].view(np.float32)

    @property
    def is_leaf(self) -> np.ndarray:
        """(M,) bool leaf mask."""
        return (self.nodes[:, 7] & LEAF_FLAG) != 0

    @property
    def leaf_first(self) -> np.ndarray:
        """(M,) int64 first reordered triangle of each leaf (meaningless for interior nodes)."""
        return self.nodes[:, 3].astype(np.int64)

    @property
    def leaf_count(self) -> np.ndarray:
        """(M,) int64 triangle count of each leaf, 0 for interior nodes."""
        return np.where(self.is_leaf, self.nodes[:, 7] & ~np.uint32(LEAF_FLAG), 0).astype(np.int64)

    def gpu_nodes(self) -> np.ndarray:
        """The layout glsl/bvh.glsl traverses: ``(I * 4, 4)`` uint32, 4 texels per INTERIOR node.

        Each interior node carries both children's boxes, so the shader tests the two boxes it
        may enter from the parent's four texels, visits the nearer child first and never fetches
        a node whose box the ray misses (leaves are not stored as nodes at all)::

            texel 0 = (left.bmin bits,  left.a)    texel 1 = (left.bmax bits,  left.b)
            texel 2 = (right.bmin bits, right.a)   texel 3 = (right.bmax bits, right.b)

        A child with ``b == 0`` is interior and ``a`` is its index here; otherwise ``b`` is
        ``count | LEAF_FLAG`` and ``a`` the first triangle. A tree that is a single leaf becomes
        one node whose left child is that leaf and whose right child is an empty leaf.
        """
        nodes, leaf = self.nodes, self.is_leaf
        if self.leaf_count.max(initial=0) > GPU_MAX_LEAF:
            raise ValueError(f"leaves of up to {self.leaf_count.max()} triangles; the GPU "
                             f"traversal handles {GPU_MAX_LEAF} (build with max_leaf <= {GPU_MAX_LEAF})")
        interior = np.flatnonzero(~leaf)
        if interior.size == 0:
            root = nodes[0]
            empty = root.copy()
            empty[3], empty[7] = 0, LEAF_FLAG
            return np.stack([root[:4], root[4:], empty[:4], empty[4:]]).astype(np.uint32)
        new_index = np.zeros(len(nodes), np.uint32)
        new_index[interior] = np.arange(interior.size, dtype=np.uint32)
        out = np.empty((interior.size, 4, 4), np.uint32)
        for slot, child in ((0, interior + 1), (2, nodes[interior, 3].astype(np.int64))):
            is_leaf = leaf[child]
            out[:, slot, :3] = nodes[child, 0:3]
            out[:, slot + 1, :3] = nodes[child, 4:7]
            out[:, slot, 3] = np.where(is_leaf, nodes[child, 3], new_index[child])
            out[:, slot + 1, 3] = np.where(is_leaf, nodes[child, 7], 0)
        return out.reshape(-1, 4)

    def stats(self) -> dict:
        """Summary numbers for logs, `mcpt info` and benchmarks."""
        counts = self.leaf_count[self.is_leaf]
        return {
            "nodes": self.num_nodes,
            "leaves": int(counts.size),
            "depth": self.depth,
            "max_leaf_size": int(counts.max()) if counts.size else 0,
            "mean_leaf_size": float(counts.mean()) if counts.size else 0.0,
            "build_seconds": self.build_seconds,
            "triangles": self.num_triangles,
        }


#: A triangle whose box diagonal exceeds this multiple of the median goes to the large subtree.
LARGE_TRIANGLE_FACTOR = 8.0


def build_bvh(tri_vertices: np.ndarray, max_leaf: int = 4) -> BVH:
    """Build a median-split BVH over triangles, large triangles in their own subtree.

    Same arguments, result and errors as :func:`build_median_bvh`.
    """
    t_start = time.perf_counter()
    tris = np.asarray(tri_vertices)
    if tris.ndim == 3 and tris.shape[1:] == (3, 3) and len(tris) > 2 * max_leaf and np.isfinite(tris).all():
        diag = np.linalg.norm(tris.max(axis=1).astype(np.float64) - tris.min(axis=1), axis=1)
        large = diag > LARGE_TRIANGLE_FACTOR * np.median(diag)
        if large.any() and not large.all():
            small_ids, large_ids = np.flatnonzero(~large), np.flatnonzero(large)
            joined = _join(build_median_bvh(tris[small_ids], max_leaf), small_ids,
                           build_median_bvh(tris[large_ids], max_leaf), large_ids)
            return BVH(joined.nodes, joined.order, joined.depth, max_leaf,
                       time.perf_counter() - t_start)
    return build_median_bvh(tri_vertices, max_leaf)


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


def build_median_bvh(tri_vertices: np.ndarray, max_leaf: int = 4) -> BVH:
    """Build a pure median-split BVH over triangles.

    Args:
        tri_vertices: (F, 3, 3) corner positions (triangle, corner, xyz) in scene units,
            float32 or float64; must be finite. F = 0 gives a single empty leaf that no ray hits.
        max_leaf: maximum triangles per leaf (>= 1).

    Returns:
        The flattened `BVH` (see the module docstring for the node layout).

    Raises:
        ValueError: bad shape, non-finite coordinates, max_leaf < 1, or F >= 2^31.
        RuntimeError: the tree would be deeper than the GPU stack allows (`MAX_STACK`).
    """
    t_start = time.perf_counter()
    tris = np.asarray(tri_vertices)
    if tris.ndim != 3 or tris.shape[1:] != (3, 3):
        raise ValueError(f"tri_vertices must have shape (F, 3, 3), got {tris.shape}")
    if not 1 <= int(max_leaf) < LEAF_FLAG:
        raise ValueError(f"max_leaf must be in [1, 2^31), got {max_leaf}")
    max_leaf = int(max_leaf)
    n_tris = tris.shape[0]
    if n_tris >= LEAF_FLAG:
        raise ValueError(f"{n_tris} triangles do not fit the 31-bit leaf fields")
    tris = tris.astype(np.float64, copy=False)
    if not np.isfinite(tris).all():
        bad = int((~np.isfinite(tris).all(axis=(1, 2))).sum())
        raise ValueError(f"{bad} triangles have non-finite coordinates")

    if n_tris == 0:
        # Inverted box (+inf, -inf): every slab test misses, so an empty scene renders black.
        nodes = np.zeros((1, 8), np.uint32)
        nodes[0, 0:3] = np.full(3, np.inf, np.float32).view(np.uint32)
        nodes[0, 4:7] = np.full(3, -np.inf, np.float32).view(np.uint32)
        nodes[0, 7] = LEAF_FLAG
        return BVH(nodes, np.zeros(0, np.int64), 1, max_leaf, time.perf_counter() - t_start)

    centroids = (tris[:, 0] + tris[:, 1] + tris[:, 2]) / 3.0  # (F, 3); 4x faster than mean(axis=1)
    levels, order = _split_levels(centroids, max_leaf)
    nodes = _flatten(levels, order, tris, n_tris)
    depth = len(levels)
    if depth + 2 > MAX_STACK:
        raise RuntimeError(f"BVH depth {depth} needs a traversal stack larger than MAX_STACK={MAX_STACK}")
    return BVH(nodes, order.astype(np.int64), depth, max_leaf, time.perf_counter() - t_start)


# --------------------------------------------------------------------------------------------
# build internals


@dataclass
class _Level:
    """Nodes of one tree level; node ids are `first_id + arange(len(start))`."""

    first_id: int
    start: np.ndarray  # first position of the node's triangles in the sorted lists
    count: np.ndarray  # number of triangles
    left: np.ndarray  # id of the left child (right = left + 1), -1 for a leaf
    axis: np.ndarray  # split axis, -1 for a leaf


def _split_levels(centroids: np.ndarray, max_leaf: int) -> tuple[list[_Level], np.ndarray]:
    """Split nodes level by level; returns the levels and the final triangle order."""
    n_tris = len(centroids)
    # lists[k] = triangle ids grouped by node, sorted by centroid k inside each node. Stable
    # sorts keep ties in id order, which makes the build deterministic.
    lists = np.stack([np.argsort(centroids[:, k], kind="stable") for k in range(3)])
    flat_lists = lists.reshape(-1)  # view: flat_lists[k * F + i] is lists[k, i]
    goes_right = np.zeros(n_tris, dtype=bool)  # scratch, only read where just written

    levels: list[_Level] = []
    start = np.zeros(1, np.int64)
    count = np.array([n_tris], np.int64)
    first_id = 0
    while start.size:
        split = count > max_leaf
        n_split = int(split.sum())
        next_id = first_id + start.size
        left = np.full(start.size, -1, np.int64)
        left[split] = next_id + 2 * np.arange(n_split)
        axis = np.full(start.size, -1, np.int64)
        levels.append(_Level(first_id, start, count, left, axis))
        if n_split == 0:
            break

        s, c = start[split], count[split]
        last = s + c - 1
        # Each list is sorted inside the node, so centroid bounds are its first/last entries.
        extent = np.stack(
            [centroids[lists[k, last], k] - centroids[lists[k, s], k] for k in range(3)], axis=1
        )
        node_axis = np.argmax(extent, axis=1)  # all-equal centroids: axis 0, split by position
        axis[split] = node_axis
        mid = s + c // 2  # object median: the left child gets floor(c / 2) triangles

        # Positions of all triangles of the splitting nodes, as one flat array.
        seg = np.repeat(np.arange(n_split), c)
        seg_offset = np.cumsum(c) - c  # where each node starts inside `pos`
        pos = np.arange(seg.size) + np.repeat(s - seg_offset, c)
        seg_start, seg_mid = s[seg], mid[seg]

        # Side of every triangle: the upper half of its node's list on the node's split axis.
        # (Flat indices: 1-D fancy indexing is much faster than lists[axis, pos].)
        goes_right[flat_lists[node_axis[seg] * n_tris + pos]] = pos >= seg_mid

        # Stable partition of every list inside every node: left triangles keep their order
        # from the node start, right ones from the median.
        pos_in_node = pos - seg_start
        for k in range(3):
            ids = lists[k][pos]
            is_left = ~goes_right[ids]
            n_left_incl = np.cumsum(is_left)
            before_node = np.concatenate(([0], n_left_incl))[seg_offset]
            left_rank = n_left_incl - is_left - before_node[seg]
            new_pos = np.where(is_left, seg_start + left_rank, seg_mid + (pos_in_node - left_rank))
            lists[k][new_pos] = ids

        start = np.stack([s, mid], axis=1).ravel()
        count = np.stack([c // 2, c - c // 2], axis=1).ravel()
        first_id = next_id
    # Leaves never move once made, so every list now holds the same leaf-ordered permutation.
    return levels, lists[0]


def _round_out(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Round float64 box corners outward to float32 values (returned as float64)."""
    lo32 = lo.astype(np.float32)
    hi32 = hi.astype(np.float32)
    lo32 = np.where(lo32.astype(np.float64) > lo, np.nextafter(lo32, np.float32(-np.inf)), lo32)
    hi32 = np.where(hi32.astype(np.float64) < hi, np.nextafter(hi32, np.float32(np.inf)), hi32)
    return lo32.astype(np.float64), hi32.astype(np.float64)


def _flatten(levels: list[_Level], order: np.ndarray, tris: np.ndarray, n_tris: int) -> np.ndarray:
    """Compute boxes bottom-up, renumber depth-first pre-order, pack (M, 8) uint32."""
    start = np.concatenate([lv.start for lv in levels])
    count = np.concatenate([lv.count for lv in levels])
    left = np.concatenate([lv.left for lv in levels])
    axis = np.concatenate([lv.axis for lv in levels])
    n_nodes = start.size
    leaf = left < 0

    # Leaf boxes: leaves partition [0, F) of the final order, so one reduceat does them all.
    leaf_ids = np.flatnonzero(leaf)
    leaf_ids = leaf_ids[np.argsort(start[leaf_ids])]
    tri_lo = np.minimum(np.minimum(tris[:, 0], tris[:, 1]), tris[:, 2])[order]
    tri_hi = np.maximum(np.maximum(tris[:, 0], tris[:, 1]), tris[:, 2])[order]
    lo = np.empty((n_nodes, 3))
    hi = np.empty((n_nodes, 3))
    lo[leaf_ids], hi[leaf_ids] = _round_out(
        np.minimum.reduceat(tri_lo, start[leaf_ids], axis=0),
        np.maximum.reduceat(tri_hi, start[leaf_ids], axis=0),
    )

    # Interior boxes and subtree sizes bottom-up; children always live on the next level.
    subtree = np.ones(n_nodes, np.int64)
    for lv in reversed(levels):
        ids = lv.first_id + np.flatnonzero(lv.left >= 0)
        if ids.size == 0:
            continue
        lc = left[ids]
        lo[ids] = np.minimum(lo[lc], lo[lc + 1])  # exact: children are already float32 values
        hi[ids] = np.maximum(hi[lc], hi[lc + 1])
        subtree[ids] = 1 + subtree[lc] + subtree[lc + 1]

    # Depth-first pre-order: left child right after its parent, right child after the whole
    # left subtree. Lets the shader skip storing the left index.
    pre = np.zeros(n_nodes, np.int64)
    for lv in levels:
        ids = lv.first_id + np.flatnonzero(lv.left >= 0)
        lc = left[ids]
        pre[lc] = pre[ids] + 1
        pre[lc + 1] = pre[ids] + 1 + subtree[lc]

    right = np.where(leaf, 0, left + 1)  # 0: placeholder index for leaves, masked below
    a = np.where(leaf, start, pre[right])
    b = np.where(leaf, count | LEAF_FLAG, axis)
    nodes = np.empty((n_nodes, 8), np.uint32)
    nodes[pre, 0:3] = lo.astype(np.float32).view(np.uint32)
    nodes[pre, 3] = a
    nodes[pre, 4:7] = hi.astype(np.float32).view(np.uint32)
    nodes[pre, 7] = b
    return nodes

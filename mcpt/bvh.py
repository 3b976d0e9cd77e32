"""Median-split bounding volume hierarchy over triangles, flattened for the GPU.

Build: object-median splits. Each node is split at the object median of one axis, the axis
chosen among the three by the surface area heuristic (SAH: MacDonald & Booth 1990), and a node
of at most ``max_leaf`` triangles stays a leaf where SAH prices the leaf no dearer than its best
split; SAH prices are loop iterations of glsl/bvh.glsl, where a node step and a triangle test
cost the same (SAH_STEP_COST, SAH_TRI_COST). Above SAH_MAX_TRIANGLES, or with ``sah=False``,
the longest axis of the centroid bounds is split down to ``max_leaf`` (the build's cost). The tree is
built level by level with every node of a level handled by the same numpy operations, so the
Python work is O(depth), not O(triangles) or O(nodes): three index lists, each sorted by one
centroid axis, are kept grouped by node and sorted inside every node; splitting a node at its
median on axis k is then "the first half of list k goes left", and all three lists are
stable-partitioned with one cumulative sum per level (the classic presorted kd-tree build).
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
    "brute_force_closest_hit",
    "bvh_closest_hit",
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
#: Leaf-size cap of the default build (SAH may stop earlier only below it).
DEFAULT_MAX_LEAF = 4
#: SAH prices in loop iterations of glsl/bvh.glsl: a node step and a triangle test are one
#: iteration each (same four fetches), so visiting a node costs as much as testing a triangle.
SAH_STEP_COST = 1.0
SAH_TRI_COST = 1.0
#: A ray entering the root box is expected to run more loop iterations than this: with up to 16
#: rays per path, one item per iteration would approach llvmpipe's 65535-iteration limit
#: (common.glsl), so the tree is traversed with wide leaves instead (BVH.dense). Ordinary meshes
#: stay far below (bunny ~38, 10^6 random triangles in a cube ~410); a cluster of 10^4 triangles
#: whose boxes all overlap is ~2 * 10^4.
DENSE_SAH_COST = 1024.0
#: Above this many triangles the build takes the longest axis's median without pricing splits:
#: SAH pricing keeps six box rows per list moving with the partition and roughly doubles the
#: numpy build (measured, bench/bvh_build.py: 10^6 random triangles 2.0 s -> 5.1 s CPU on the
#: shared 2-core machine), and the 10^6-triangle build must stay fast (issue #14).
SAH_MAX_TRIANGLES = 1 << 18
#: glsl/bvh.glsl item references: texel address in the low 28 bits, leaf count above.
GPU_COUNT_SHIFT = 28
GPU_ADDRESS_LIMIT = 1 << GPU_COUNT_SHIFT


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

    @property
    def dense(self) -> bool:
        """Rays must test so many triangles here (SAH cost above DENSE_SAH_COST iterations per
        ray) that glsl/bvh.glsl's one-item-per-iteration traversal would reach llvmpipe's loop
        limit: such trees get the wide-leaf traversal (MCPT_BVH_DENSE, ``gpu_nodes(dense=True)``)."""
        return self.worst_sah_cost() > DENSE_SAH_COST

    def gpu_nodes(self, tris_reordered: np.ndarray, dense: bool = False) -> np.ndarray:
        """The buffer glsl/bvh.glsl traverses: ``(4 I + 3 F + 1, 4)`` uint32 RGBA32UI texels.

        Interior nodes first (node k at texel 4k, the root at 0), each holding both children's
        boxes, so the shader tests the two boxes it may enter from one record and never fetches
        a record whose box the ray misses::

            texel 0 = (left.bmin bits,  left.ref)    texel 1 = (left.bmax bits,  0)
            texel 2 = (right.bmin bits, right.ref)   texel 3 = (right.bmax bits, 0)

        then one record per triangle in BVH order (triangle j at texel 4I + 3j)::

            (v0 bits, j), (v1 bits, 0), (v2 bits, 0)

        and one pad texel (the shader always reads four texels). A child reference is the
        texel address of its record, plus ``count << 28`` for a leaf of ``count`` consecutive
        triangle records. Nodes and triangles share the buffer so one traversal step reads a node
        OR a triangle with the same four fetches (issue #14). A tree that is a single leaf becomes
        one node whose right child is an empty box no ray enters.

        Args:
            tris_reordered: (F, 3, 3) float32 triangles in BVH order (``tris[bvh.order]``), in the
                frame the shader traces in.
            dense: the layout of the wide-leaf traversal instead (:meth:`dense_nodes`).
        """
        if dense:
            return self.dense_nodes()
        tris = np.ascontiguousarray(tris_reordered, dtype=np.float32)
        n_tris = self.num_triangles
        if tris.shape != (n_tris, 3, 3):
            raise ValueError(f"tris_reordered must have shape ({n_tris}, 3, 3), got {tris.shape}")
        nodes, leaf = self.nodes, self.is_leaf
        counts = self.leaf_count
        if counts.max(initial=0) > GPU_MAX_LEAF:
            raise ValueError(f"leaves of up to {counts.max()} triangles; the GPU "
                             f"traversal handles {GPU_MAX_LEAF} (build with max_leaf <= {GPU_MAX_LEAF})")
        interior = np.flatnonzero(~leaf)
        n_records = max(interior.size, 1)
        tri_base = 4 * n_records
        total = tri_base + 3 * n_tris + 1
        if total > GPU_ADDRESS_LIMIT:
            raise ValueError(f"{total} texels do not fit the 28-bit references of the traversal")
        out = np.zeros((total, 4), np.uint32)
        tri_texels = out[tri_base:tri_base + 3 * n_tris].reshape(n_tris, 3, 4)
        tri_texels[:, :, :3] = tris.view(np.uint32)
        tri_texels[:, 0, 3] = np.arange(n_tris, dtype=np.uint32)

        def ref(child: np.ndarray) -> np.ndarray:
            is_leaf = leaf[child]
            leaf_ref = (tri_base + 3 * nodes[child, 3].astype(np.int64)) | (counts[child] << GPU_COUNT_SHIFT)
            return np.where(is_leaf, leaf_ref, 4 * new_index[child]).astype(np.uint32)

        recs = out[:tri_base].reshape(n_records, 4, 4)
        if interior.size == 0:
            recs[0, 0, :3], recs[0, 1, :3] = nodes[0, 0:3], nodes[0, 4:7]
            recs[0, 0, 3] = tri_base | (n_tris << GPU_COUNT_SHIFT) if n_tris else 0
            recs[0, 2, :3] = np.full(3, np.inf, np.float32).view(np.uint32)   # empty box
            recs[0, 3, :3] = np.full(3, -np.inf, np.float32).view(np.uint32)
            recs[0, 2, 3] = recs[0, 0, 3]
            return out
        new_index = np.zeros(len(nodes), np.int64)
        new_index[interior] = np.arange(interior.size)
        for slot, child in ((0, interior + 1), (2, nodes[interior, 3].astype(np.int64))):
            recs[:, slot, :3] = nodes[child, 0:3]
            recs[:, slot + 1, :3] = nodes[child, 4:7]
            recs[:, slot, 3] = ref(child)
        return out

    def dense_nodes(self) -> np.ndarray:
        """Layout of the wide-leaf traversal (glsl/bvh.glsl, MCPT_BVH_DENSE): ``(I * 4, 4)``
        uint32, 4 texels per INTERIOR node holding both children's boxes::

            texel 0 = (left.bmin bits,  left.a)    texel 1 = (left.bmax bits,  left.b)
            texel 2 = (right.bmin bits, right.a)   texel 3 = (right.bmax bits, right.b)

        A child with ``b == 0`` is interior and ``a`` is its index here; otherwise ``b`` is
        ``count | LEAF_FLAG`` and ``a`` the first triangle (in u_tris). A tree that is a single
        leaf becomes one node whose right child is an empty leaf.
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
            "sah_cost": self.sah_cost(),
        }

    def worst_sah_cost(self) -> float:
        """The largest SAH cost of any subtree, relative to its own box: the iterations a ray
        entering that box expects. A cluster whose boxes all overlap shows here even when it
        fills a small part of the root box (then ``sah_cost`` stays small)."""
        area, price = self._sah_terms()
        n = len(area)
        idx = np.arange(n)
        # Pre-order: a subtree is the index range [i, end_i), end_i = 1 + the last node on i's
        # right spine; pointer doubling finds it in log2(depth) vectorised steps.
        ptr = np.where(self.is_leaf, idx, self.nodes[:, 3].astype(np.int64))
        for _ in range(max(1, int(np.ceil(np.log2(self.depth + 1))))):
            ptr = ptr[ptr]
        acc = np.concatenate([[0.0], np.cumsum(area * price)])
        ok = area > 0.0
        if not ok.any():
            return 0.0
        return float(((acc[ptr + 1] - acc[idx])[ok] / area[ok]).max())

    def _sah_terms(self) -> tuple[np.ndarray, np.ndarray]:
        e = np.maximum(self.bounds_max.astype(np.float64) - self.bounds_min, 0.0)
        with np.errstate(invalid="ignore", over="ignore"):
            area = e[:, 0] * e[:, 1] + e[:, 1] * e[:, 2] + e[:, 2] * e[:, 0]
        area = np.where(np.isfinite(area), area, 0.0)
        price = np.where(self.is_leaf, self.leaf_count * SAH_TRI_COST, SAH_STEP_COST)
        return area, price

    def sah_cost(self) -> float:
        """Expected loop iterations of a ray that enters the root box, by the surface area
        heuristic (MacDonald & Booth 1990): each node is entered with probability area(node) /
        area(root) and then costs SAH_STEP_COST (interior) or count * SAH_TRI_COST (leaf)."""
        area, price = self._sah_terms()
        if area[0] <= 0.0:
            return float("nan")
        return float((area * price).sum() / area[0])


#: A triangle whose box diagonal exceeds this multiple of the median goes to the large subtree.
LARGE_TRIANGLE_FACTOR = 8.0


def build_bvh(tri_vertices: np.ndarray, max_leaf: int = DEFAULT_MAX_LEAF, sah: bool = True) -> BVH:
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
            joined = _join(build_median_bvh(tris[small_ids], max_leaf, sah), small_ids,
                           build_median_bvh(tris[large_ids], max_leaf, sah), large_ids)
            return BVH(joined.nodes, joined.order, joined.depth, max_leaf,
                       time.perf_counter() - t_start)
    return build_median_bvh(tri_vertices, max_leaf, sah)


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
    boxes = None
    if sah and n_tris <= SAH_MAX_TRIANGLES:
        boxes = np.empty((6, n_tris), np.float32)   # (lo, -hi) per column: mins only
        boxes[:3] = tris.min(axis=1).T
        boxes[3:] = -tris.max(axis=1).T
    levels, order = _split_levels(centroids, boxes, max_leaf)
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


def _split_levels(centroids: np.ndarray, boxes: np.ndarray | None,
                  max_leaf: int) -> tuple[list[_Level], np.ndarray]:
    """Split nodes level by level; returns the levels and the final triangle order.

    ``boxes`` (6, F) float32 triangle boxes as (lo, -hi), or None: split every node at the object
    median of its longest centroid axis (the plain median tree). With boxes, the three axes'
    object medians are scored by SAH and the cheapest taken; a node of at most ``max_leaf``
    triangles stays a leaf when SAH prices the leaf at most at its best split. Larger nodes
    always split, so leaves respect the cap either way.
    """
    n_tris = len(centroids)
    # lists[k] = triangle ids grouped by node, sorted by centroid k inside each node. numpy's
    # default sort is deterministic (same input, same order of ties) and 4x faster than its
    # stable sort. int32 halves the memory traffic of the per-level gathers and scatters.
    lists = np.stack([np.argsort(centroids[:, k]).astype(np.int32) for k in range(3)])
    flat_lists = lists.reshape(-1)  # view: flat_lists[k * F + i] is lists[k, i]
    goes_right = np.zeros(n_tris, dtype=bool)  # scratch, only read where just written
    cent32 = [np.ascontiguousarray(centroids[:, k]) for k in range(3)]
    # With SAH: the boxes in each list's order, (3, 6, F), moved along with the lists. Partition
    # moves stay inside a node's range (cache-friendly at depth), and reading a node's boxes is
    # then a contiguous slice instead of a random gather by triangle id.
    list_boxes = None if boxes is None else np.stack([boxes[:, lists[k]] for k in range(3)])

    levels: list[_Level] = []
    start = np.zeros(1, np.int64)
    count = np.array([n_tris], np.int64)
    first_id = 0
    while start.size:
        split = count > (1 if boxes is not None else max_leaf)
        s, c = start[split], count[split]
        n_split = s.size
        if n_split == 0:
            levels.append(_Level(first_id, start, count, np.full(start.size, -1, np.int64),
                                 np.full(start.size, -1, np.int64)))
            break
        last = s + c - 1
        mid = s + c // 2  # object median: the left child gets floor(c / 2) triangles

        # Positions of all triangles of the splitting nodes, as one flat array.
        # int32 throughout: these arrays hold one entry per triangle and dominate the build time.
        seg = np.repeat(np.arange(n_split, dtype=np.int32), c)
        seg_offset = np.cumsum(c) - c  # where each node starts inside `pos`
        pos = np.arange(seg.size, dtype=np.int32) + np.repeat((s - seg_offset).astype(np.int32), c)

        list_ids = None
        if boxes is None:
            # Each list is sorted inside the node, so centroid bounds are its first/last entries.
            extent = np.stack([cent32[k][lists[k, last]] - cent32[k][lists[k, s]] for k in range(3)], axis=1)
            node_axis = np.argmax(extent, axis=1)  # all-equal centroids: axis 0, split by position
        else:
            full = pos.size == n_tris  # every triangle still splits: pos is 0 .. F-1
            list_ids = [lists[k] if full else lists[k][pos] for k in range(3)]
            node_boxes = [list_boxes[k] if full else list_boxes[k][:, pos] for k in range(3)]
            node_axis, keep_leaf = _sah_choice(node_boxes, seg_offset, c, max_leaf)
            if keep_leaf.any():
                # Nodes SAH keeps as leaves drop out of this level's split.
                idx = np.flatnonzero(split)
                split[idx[keep_leaf]] = False
                go = ~keep_leaf
                s, c, last, mid, node_axis = s[go], c[go], last[go], mid[go], node_axis[go]
                n_split = s.size
                seg_keep = np.repeat(go, count[idx])
                seg_offset = np.cumsum(c) - c
                pos = pos[seg_keep]
                list_ids = [ids[seg_keep] for ids in list_ids]
                node_boxes = [b[:, seg_keep] for b in node_boxes]
                seg = np.repeat(np.arange(n_split, dtype=np.int32), c)
        next_id = first_id + start.size
        left = np.full(start.size, -1, np.int64)
        left[split] = next_id + 2 * np.arange(n_split)
        axis = np.full(start.size, -1, np.int64)
        axis[split] = node_axis
        levels.append(_Level(first_id, start, count, left, axis))
        if n_split == 0:
            break

        seg_start, seg_mid = s.astype(np.int32)[seg], mid.astype(np.int32)[seg]
        # Side of every triangle: the upper half of its node's list on the node's split axis.
        # (Flat indices: 1-D fancy indexing is much faster than lists[axis, pos].)
        goes_right[flat_lists[node_axis[seg] * np.int64(n_tris) + pos]] = pos >= seg_mid

        # Stable partition of every list inside every node: left triangles keep their order
        # from the node start, right ones from the median. The split axis's own list is already
        # partitioned (its lower half is the left child), so only the other two move.
        pos_in_node = pos - seg_start
        for k in range(3):
            if (node_axis == k).all():
                continue
            ids = lists[k][pos] if list_ids is None else list_ids[k]
            is_left = ~goes_right[ids]
            n_left_incl = np.cumsum(is_left, dtype=np.int32)
            before_node = np.concatenate((np.zeros(1, np.int32), n_left_incl))[seg_offset]
            left_rank = n_left_incl - is_left - before_node[seg]
            new_pos = np.where(is_left, seg_start + left_rank, seg_mid + (pos_in_node - left_rank))
            lists[k][new_pos] = ids
            if list_boxes is not None:
                list_boxes[k][:, new_pos] = node_boxes[k]

        start = np.stack([s, mid], axis=1).ravel()
        count = np.stack([c // 2, c - c // 2], axis=1).ravel()
        first_id = next_id
    # Leaves never move once made, so every list now holds the same leaf-ordered permutation.
    return levels, lists[0].astype(np.int64)


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


# --------------------------------------------------------------------------------------------
# CPU reference intersection (tests, debugging): float64 throughout.

# Relative slack on slab-test distances: more than the rounding error of the slab arithmetic
# (pbrt's 1 + 2 * gamma(3)), so a hit on a box face is never culled.
_SLAB_PAD = 1.0 + 8.0 * np.finfo(np.float64).eps


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product, written out so every row rounds the same way in any batch."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.stack(
        [
            a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
            a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
            a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0],
        ],
        axis=1,
    )


def _moller_trumbore(tris: np.ndarray, o: np.ndarray, d: np.ndarray, tmin: float) -> np.ndarray:
    """Ray-triangle distances for matching rows of (n, 3, 3) tris and (n, 3) rays; inf = miss.

    t is in units of |d|. Both references below call this same function on the same float64
    data, so equal (ray, triangle) pairs give bit-identical t.
    """
    v0 = tris[:, 0]
    e1 = tris[:, 1] - v0
    e2 = tris[:, 2] - v0
    p = _cross(d, e2)
    det = _dot(e1, p)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_det = 1.0 / det
        s = o - v0
        u = _dot(s, p) * inv_det
        q = _cross(s, e1)
        v = _dot(d, q) * inv_det
        t = _dot(e2, q) * inv_det
        hit = (det != 0.0) & (u >= 0.0) & (v >= 0.0) & (u + v <= 1.0) & (t > tmin)
    return np.where(hit, t, np.inf)


def _check_rays(origins: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    o = np.asarray(origins, dtype=np.float64)
    d = np.asarray(dirs, dtype=np.float64)
    if o.ndim != 2 or o.shape[1] != 3 or d.shape != o.shape:
        raise ValueError(f"origins and dirs must both be (R, 3), got {o.shape} and {d.shape}")
    return o, d


def brute_force_closest_hit(
    tris: np.ndarray, origins: np.ndarray, dirs: np.ndarray, tmin: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Closest hit of every ray against every triangle (reference for tests).

    Möller–Trumbore in float64 on all (ray, triangle) pairs that survive a conservative
    bounding-sphere pre-test. The pre-test is only a speed-up (it evaluates every pair, in
    chunks of rays, with two small matrix products): a triangle hit by a ray lies within its
    bounding sphere, and the sphere radius is padded far beyond the rounding error, so no hit
    is lost. Ties in t go to the lowest triangle index.

    Args:
        tris: (F, 3, 3) triangle corners.
        origins, dirs: (R, 3) ray origins and directions (directions need not be unit).
        tmin: hits need t > tmin (t in units of |dir|).

    Returns:
        t: (R,) float64 hit distance, inf for a miss; tri: (R,) int64 triangle index, -1 for a miss.
    """
    tris = np.asarray(tris, dtype=np.float64)
    o, d = _check_rays(origins, dirs)
    n_rays, n_tris = len(o), len(tris)
    best_t = np.full(n_rays, np.inf)
    best_i = np.full(n_rays, -1, np.int64)
    if n_rays == 0 or n_tris == 0:
        return best_t, best_i

    center = tris.mean(axis=1)
    radius = np.sqrt(((tris - center[:, None, :]) ** 2).sum(axis=2).max(axis=1))
    # Distance^2 from line (o, u), |u| = 1, to center c:  |c - o|^2 - ((c - o) . u)^2, expanded
    # into products of per-ray and per-triangle vectors so a chunk is two matrix products:
    #   A = u . c - u . o                    = [u, -u.o]            @ [c, 1]
    #   B = |c|^2 - 2 c.o + |o|^2 - r'^2     = [-2o, |o|^2 - tol, 1] @ [c, 1, |c|^2 - r'^2]
    # and the pair survives when B <= A^2. tol covers the cancellation error of the expansion
    # (~ eps (|c|^2 + |o|^2)) with a factor of ~100 to spare.
    unit = d / np.linalg.norm(d, axis=1, keepdims=True)
    c2 = (center**2).sum(axis=1)
    r_pad = radius * (1.0 + 1e-9)
    tri_a = np.concatenate([center, np.ones((n_tris, 1))], axis=1).T.copy()
    tri_b = np.concatenate([center, np.ones((n_tris, 1)), (c2 - r_pad**2)[:, None]], axis=1).T.copy()
    o2 = (o**2).sum(axis=1)
    tol = 1e-12 * (c2.max() + o2)
    ray_a = np.concatenate([unit, -_dot(unit, o)[:, None]], axis=1)
    ray_b = np.concatenate([-2.0 * o, (o2 - tol)[:, None], np.ones((n_rays, 1))], axis=1)

    chunk = max(1, 2_000_000 // n_tris)  # ~16 MB float64 per temporary
    for r0 in range(0, n_rays, chunk):
        r1 = min(n_rays, r0 + chunk)
        proj = ray_a[r0:r1] @ tri_a
        near = ray_b[r0:r1] @ tri_b <= proj * proj
        ray_idx, tri_idx = np.nonzero(near)
        if ray_idx.size == 0:
            continue
        ray_idx += r0
        t = _moller_trumbore(tris[tri_idx], o[ray_idx], d[ray_idx], tmin)
        hit = np.isfinite(t)
        ray_idx, tri_idx, t = ray_idx[hit], tri_idx[hit], t[hit]
        # Per ray: smallest t, then smallest triangle index.
        srt = np.lexsort((tri_idx, t, ray_idx))
        ray_idx, tri_idx, t = ray_idx[srt], tri_idx[srt], t[srt]
        first = np.ones(ray_idx.size, bool)
        first[1:] = ray_idx[1:] != ray_idx[:-1]
        best_t[ray_idx[first]] = t[first]
        best_i[ray_idx[first]] = tri_idx[first]
    return best_t, best_i


def bvh_closest_hit(
    bvh: BVH, tris_reordered: np.ndarray, origins: np.ndarray, dirs: np.ndarray, tmin: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Closest hit by walking the packed node array, like the GLSL traversal (reference).

    Vectorised over rays: every step, each unfinished ray handles one node from its own
    stack (front-to-back: the near child by the ray's direction sign on the split axis is
    visited first, the far one pushed). Exact ties in t go to the lowest ORIGINAL triangle
    index, matching `brute_force_closest_hit` on the original order.

    Args:
        bvh: the hierarchy.
        tris_reordered: (F, 3, 3) triangles in BVH order, i.e. `tris[bvh.order]`.
        origins, dirs: (R, 3) rays; tmin: hits need t > tmin (t in units of |dir|).

    Returns:
        t: (R,) float64, inf for a miss; tri: (R,) int64 REORDERED triangle index, -1 for a miss
        (`bvh.order[tri]` is the original index).
    """
    tris = np.asarray(tris_reordered, dtype=np.float64)
    o, d = _check_rays(origins, dirs)
    if len(tris) != bvh.num_triangles:
        raise ValueError(f"{len(tris)} triangles given, the BVH has {bvh.num_triangles}")
    n_rays = len(o)
    best_t = np.full(n_rays, np.inf)
    best_i = np.full(n_rays, -1, np.int64)

    lo = bvh.bounds_min.astype(np.float64)
    hi = bvh.bounds_max.astype(np.float64)
    is_leaf = bvh.is_leaf
    a_field = bvh.nodes[:, 3].astype(np.int64)
    b_field = bvh.nodes[:, 7].astype(np.int64)
    leaf_count = np.where(is_leaf, b_field & (LEAF_FLAG - 1), 0)
    order = bvh.order
    with np.errstate(divide="ignore"):
        inv_d = 1.0 / d

    stack = np.zeros((n_rays, MAX_STACK), np.int64)
    sp = np.zeros(n_rays, np.int64)
    node = np.zeros(n_rays, np.int64)
    live = np.arange(n_rays)
    while live.size:
        n = node[live]
        ro, rinv = o[live], inv_d[live]
        with np.errstate(invalid="ignore"):
            # nan (0 * inf: origin on a slab plane, direction parallel) is ignored by fmin/fmax.
            t0 = (lo[n] - ro) * rinv
            t1 = (hi[n] - ro) * rinv
            t_near = np.fmax.reduce(np.fmin(t0, t1), axis=1)
            t_far = np.fmin.reduce(np.fmax(t0, t1), axis=1)
        enter = np.maximum(t_near, tmin) <= np.minimum(t_far, best_t[live]) * _SLAB_PAD

        # Leaves: test their triangles, then pop.
        at_leaf = enter & is_leaf[n]
        rays = live[at_leaf]
        first, cnt = a_field[n[at_leaf]], leaf_count[n[at_leaf]]
        for j in range(int(cnt.max()) if cnt.size else 0):
            m = j < cnt
            r, tri = rays[m], first[m] + j
            t = _moller_trumbore(tris[tri], o[r], d[r], tmin)
            cur = best_i[r]
            better = (t < best_t[r]) | (
                (t == best_t[r]) & np.isfinite(t) & (order[tri] < np.where(cur >= 0, order[cur], np.inf))
            )
            best_t[r[better]] = t[better]
            best_i[r[better]] = tri[better]

        # Interior nodes: go to the near child, push the far one.
        inner = enter & ~is_leaf[n]
        rays, parent = live[inner], n[inner]
        split_axis = b_field[parent]
        left_first = d[rays, split_axis] >= 0.0
        near = np.where(left_first, parent + 1, a_field[parent])
        far = np.where(left_first, a_field[parent], parent + 1)
        if rays.size and sp[rays].max() >= MAX_STACK:
            raise RuntimeError("traversal stack overflow")
        stack[rays, sp[rays]] = far
        sp[rays] += 1
        node[rays] = near

        # Missed boxes and finished leaves: pop, or retire the ray when its stack is empty.
        done = live[~inner]
        has_more = sp[done] > 0
        pop = done[has_more]
        sp[pop] -= 1
        node[pop] = stack[pop, sp[pop]]
        live = np.concatenate([rays, pop])
    return best_t, best_i

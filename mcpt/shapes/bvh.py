"""The bounding volume hierarchy: the tree record, its SAH cost and its GPU layout (glsl/bvh.glsl).

The tree is built by mcpt/shapes/bvh_build.py (object-median splits, the axis and the leaves
chosen by SAH, large triangles in a subtree of their own; above SAH_MAX_TRIANGLES the longest
axis's median, mcpt/shapes/bvh_median.py) and packed by mcpt/shapes/bvh_flatten.py.

The tree record (`BVH.nodes`, (M, 8) uint32, row i = node i; the shader reads the GPU layouts
below, built from it)::

    words 0-3 = (bmin.x, bmin.y, bmin.z, a)      bmin/bmax: float32 bit patterns
    words 4-7 = (bmax.x, bmax.y, bmax.z, b)
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

The GPU layouts (:meth:`BVH.gpu_nodes`, :meth:`BVH.dense_nodes`) grow every box outward
(:func:`grown_boxes`), so a ray running exactly along a box face, with a zero direction
component (the shader replaces it by 1e-30), starts strictly inside that slab and stays in it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..parallel import ordered, row_chunks, side_by_side
from .geometry import pack_triangles
from .rows import put_rows, take_rows

__all__ = [
    "BVH",
    "LEAF_FLAG",
    "MAX_STACK",
]

#: Size of the per-ray traversal stack in the GLSL shader (entries of node indices). The stack
#: holds at most one deferred (far) child per level, so depth + 2 entries are always enough;
#: `build_bvh` refuses trees that would overflow it (median splits reach depth 62 only at
#: 2^60 triangles, so this never fires in practice).
MAX_STACK = 64

#: Top bit of word 7 (b) marks a leaf; the remaining 31 bits hold the triangle count.
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


#: Boxes in the GPU layouts are grown outward by GPU_BOX_GROWTH |coordinate| (>= 2 float32 ulps of
#: it) plus GPU_BOX_FLOOR times the scene's extent (never 0 at a coordinate 0, and tiny: a
#: centimetre mesh on a 10 km plane keeps its boxes).
GPU_BOX_GROWTH = 2.0 ** -21
GPU_BOX_FLOOR = 2.0 ** -60


def grown_boxes(bmin: np.ndarray, bmax: np.ndarray, extent: float) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) float32 boxes grown outward by ``GPU_BOX_GROWTH |c| + GPU_BOX_FLOOR extent`` per
    coordinate.

    Why: a ray parallel to a slab (direction component 0, replaced by 1e-30 in glsl/bvh.glsl
    safe_inv) whose origin lies exactly on one of the slab's planes gets 0 * 1e30 = 0 there, so a
    flat box (an axis-aligned wall's) ended at t = 0 for it and was missed (issue #6, stability
    case watertight-flat-grid-axis-rays). The shader used to push such slabs out per box and per
    step (six compares and a multiply-add per box: 4-5 % of paths/s, issue #14); with every box
    grown here the origin is strictly inside by at least ``GPU_BOX_FLOOR * extent``, which times
    1e30 (~1e12 extents) is beyond any ray's reach. A few ulps more box cost no measurable
    traversal work.
    Empty boxes (+inf / -inf) stay empty."""
    lo, hi = np.asarray(bmin, np.float64), np.asarray(bmax, np.float64)
    with np.errstate(invalid="ignore"):
        glo = np.where(np.isfinite(lo), lo - (GPU_BOX_GROWTH * np.abs(lo) + GPU_BOX_FLOOR * extent), lo)
        ghi = np.where(np.isfinite(hi), hi + (GPU_BOX_GROWTH * np.abs(hi) + GPU_BOX_FLOOR * extent), hi)
    return glo.astype(np.float32), ghi.astype(np.float32)


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
    #: :meth:`worst_sah_cost`, remembered once computed: it is kept with the world in the set-up
    #: cache (mcpt/shapes/world_cache.py), so a warm set-up does not walk 5 * 10^5 nodes again.
    worst_cost: float | None = field(default=None, init=False, repr=False)

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

    def large_tail(self) -> tuple[int, int]:
        """(first, ref): the triangles first.. of the root's right subtree, where build_bvh puts
        large triangles (the walls around a dense mesh), and the reference of the root's left
        child in :meth:`gpu_nodes`' layout, where a traversal that has tested the tail on its own
        starts (glsl/bvh.glsl MCPT_BVH_START). (num_triangles, 0) for a single-leaf tree."""
        if self.is_leaf[0]:
            return self.num_triangles, 0
        right = int(self.nodes[0, 3])
        leaf = self.is_leaf
        first = int(self.leaf_first[right:][leaf[right:]].min())
        # Node 1 (the root's left child) follows the root's 4-texel record (gpu_nodes' layout).
        return first, 4 | (int(self.leaf_count[1]) << GPU_COUNT_SHIFT)

    def _grown_node_boxes(self) -> np.ndarray:
        """``self.nodes`` with every box grown outward (:func:`grown_boxes`), as (M, 8) uint32."""
        out = self.nodes.copy()
        root_lo, root_hi = self.bounds_min[0].astype(np.float64), self.bounds_max[0].astype(np.float64)
        finite = np.isfinite(root_lo).all() and np.isfinite(root_hi).all()
        extent = float(np.max(root_hi - root_lo)) if finite and self.num_triangles else 0.0
        bmin, bmax = self.bounds_min, self.bounds_max

        def grow(rows: slice) -> None:  # box by box: the rows cut into a chunk per core (issue #23)
            lo, hi = grown_boxes(bmin[rows], bmax[rows], max(extent, 1e-30))
            out[rows, 0:3] = lo.view(np.uint32)
            out[rows, 4:7] = hi.view(np.uint32)

        ordered(grow, row_chunks(len(out)))
        return out

    def gpu_nodes(self, tris_reordered: np.ndarray, dense: bool = False) -> np.ndarray:
        """The buffer glsl/bvh.glsl traverses: ``(4 I + 3 F + 1, 4)`` uint32 RGBA32UI texels.

        One record per interior node (4 texels), holding both children's boxes, so the shader
        tests the two boxes it may enter from one record and never fetches a record whose box
        the ray misses::

            texel 0 = (left.bmin bits,  left.ref)    texel 1 = (left.bmax bits,  0)
            texel 2 = (right.bmin bits, right.ref)   texel 3 = (right.bmax bits, 0)

        and one record per triangle (3 texels; j its index in BVH order)::

            (v0 bits, j), (v1 bits, 0), (v2 bits, 0)

        then one pad texel (the shader always reads four texels). The records follow the tree's
        depth-first order, a leaf's triangles where the leaf stands (the root at texel 0, a
        node's left child right after it): a subtree is one stretch of the buffer and a leaf's
        triangles lie next to their parent. Issue #23, against all nodes first, then all
        triangles: paths per CPU-second 1.00-1.05x on the bunny, the 100k and the 10^6-triangle
        spheres in two runs, the same hits (bench/RESULTS.md, stop 35; 64-byte-aligned node
        records measured 0.90-0.99x, sibling records side by side 0.92-1.03x). A child reference is the
        texel address of its record, plus ``count << 28`` for a leaf of ``count`` consecutive
        triangle records. Nodes and triangles share the buffer so one traversal step reads a node
        OR a triangle with the same four fetches (issue #14). A tree that is a single leaf becomes
        one node whose right child is an empty box (+inf / -inf; the slab test swaps its bounds, so a
        ray does enter it and tests the one leaf again: the same hits, one wasted step).

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
        nodes, leaf = self._grown_node_boxes(), self.is_leaf
        counts = self.leaf_count
        if counts.max(initial=0) > GPU_MAX_LEAF:
            raise ValueError(f"leaves of up to {counts.max()} triangles; the GPU "
                             f"traversal handles {GPU_MAX_LEAF} (build with max_leaf <= {GPU_MAX_LEAF})")
        if leaf[0]:
            out = np.zeros((4 + 3 * n_tris + 1, 4), np.uint32)
            out[4:4 + 3 * n_tris] = _triangle_records(tris)
            out[0, :3], out[1, :3] = nodes[0, 0:3], nodes[0, 4:7]
            out[0, 3] = 4 | (n_tris << GPU_COUNT_SHIFT) if n_tris else 0
            out[2, :3] = np.full(3, np.inf, np.float32).view(np.uint32)   # empty box
            out[3, :3] = np.full(3, -np.inf, np.float32).view(np.uint32)
            out[2, 3] = out[0, 3]
            return out
        return _depth_first(nodes, leaf, counts, self.leaf_first, tris)

    def dense_nodes(self) -> np.ndarray:
        """Layout of the wide-leaf traversal (glsl/bvh.glsl, MCPT_BVH_DENSE): ``(I * 4, 4)``
        uint32, 4 texels per INTERIOR node holding both children's boxes::

            texel 0 = (left.bmin bits,  left.a)    texel 1 = (left.bmax bits,  left.b)
            texel 2 = (right.bmin bits, right.a)   texel 3 = (right.bmax bits, right.b)

        A child with ``b == 0`` is interior and ``a`` is its index here; otherwise ``b`` is
        ``count | LEAF_FLAG`` and ``a`` the first triangle (in u_tris). A tree that is a single
        leaf becomes one node whose right child is an empty leaf.
        """
        nodes, leaf = self._grown_node_boxes(), self.is_leaf
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
        if self.worst_cost is None:
            object.__setattr__(self, "worst_cost", self._worst_sah_cost())
        return self.worst_cost

    def _worst_sah_cost(self) -> float:
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
        """(area / 2, price) of every node, made once (sah_cost and worst_sah_cost share them).
        A column at a time: the (M, 3) views of the node records are strided, and whole-row
        arithmetic on them cost 20 ms at 5 * 10^5 nodes (issue #23)."""
        terms = self.__dict__.get("_terms")
        if terms is None:
            lo, hi = self.bounds_min, self.bounds_max
            e = [np.maximum(hi[:, k].astype(np.float64) - lo[:, k].astype(np.float64), 0.0) for k in range(3)]
            with np.errstate(invalid="ignore", over="ignore"):
                area = e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
            area = np.where(np.isfinite(area), area, 0.0)
            flags = self.nodes[:, 7]
            count = (flags & ~np.uint32(LEAF_FLAG)).astype(np.int64)  # a leaf's leaf_count
            price = np.where((flags & LEAF_FLAG) != 0, count * SAH_TRI_COST, SAH_STEP_COST)
            terms = (area, price)
            object.__setattr__(self, "_terms", terms)  # not a field: never stored in the cache
        return terms

    def sah_cost(self) -> float:
        """Expected loop iterations of a ray that enters the root box, by the surface area
        heuristic (MacDonald & Booth 1990): each node is entered with probability area(node) /
        area(root) and then costs SAH_STEP_COST (interior) or count * SAH_TRI_COST (leaf)."""
        area, price = self._sah_terms()
        if area[0] <= 0.0:
            return float("nan")
        return float((area * price).sum() / area[0])


def _triangle_records(tris: np.ndarray) -> np.ndarray:
    """(3 F, 4) triangle records of BVH.gpu_nodes: (v0 bits, j), (v1 bits, 0), (v2 bits, 0); the
    layout of pack_triangles with the triangle's index where it has the material."""
    return pack_triangles(tris, np.arange(len(tris), dtype=np.uint32))


def _depth_first(nodes: np.ndarray, leaf: np.ndarray, counts: np.ndarray, leaf_first: np.ndarray,
                 tris: np.ndarray) -> np.ndarray:
    """BVH.gpu_nodes' buffer of a tree with an interior root: a 4-texel record per interior node
    and each leaf's triangle records (``tris``: (F, 3, 3) float32 in BVH order), in the order of
    the tree record's rows (depth-first), then a pad texel."""
    size = np.where(leaf, 3 * counts, 4)
    addr = np.cumsum(size) - size
    total = int(addr[-1] + size[-1]) + 1
    if total > GPU_ADDRESS_LIMIT:
        raise ValueError(f"{total} texels do not fit the 28-bit references of the traversal")
    out = np.zeros((total, 4), np.uint32)
    # Each job builds one record kind contiguous, then scatters it into its own texels of
    # ``out`` as whole 16-byte texels (mcpt/shapes/rows.py); the two jobs run on the thread pool
    # (mcpt/parallel.py).

    def triangles():
        leaves = np.flatnonzero(leaf)
        lc = counts[leaves]
        within = np.arange(int(lc.sum())) - np.repeat(np.cumsum(lc) - lc, lc)
        at = np.empty(len(within), np.int64)  # triangle j's record
        at[np.repeat(leaf_first[leaves], lc) + within] = np.repeat(addr[leaves], lc) + 3 * within
        put_rows(out, (at[:, None] + np.arange(3)).ravel(), _triangle_records(tris))

    def interior_nodes():
        interior = np.flatnonzero(~leaf)
        recs = np.empty((interior.size, 4, 4), np.uint32)
        halves = nodes.reshape(-1, 4)  # node i's (bmin, a) and (bmax, b) at rows 2i, 2i + 1
        for slot, child in ((0, interior + 1), (2, nodes[interior, 3].astype(np.int64))):
            recs[:, slot] = take_rows(halves, 2 * child)
            recs[:, slot + 1] = take_rows(halves, 2 * child + 1)
            recs[:, slot, 3] = (addr[child] | (counts[child] << GPU_COUNT_SHIFT)).astype(np.uint32)
            recs[:, slot + 1, 3] = 0
        put_rows(out, (addr[interior][:, None] + np.arange(4)).ravel(), recs.reshape(-1, 4))

    side_by_side(triangles, interior_nodes)
    return out

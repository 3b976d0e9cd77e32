"""The plain object-median tree (mcpt/shapes/bvh_median.py: rows split by argpartition), used above
SAH_MAX_TRIANGLES and with sah=False: structure, median balance, axis choice, closest hits."""

from __future__ import annotations

import numpy as np
import pytest

from mcpt.shapes.bvh import LEAF_FLAG
from mcpt.shapes.bvh_build import build_bvh, build_median_bvh

from .test_bvh import assert_same_hits, check_invariants, depth_bound, random_triangles


def _node_ranges(bvh) -> tuple[np.ndarray, np.ndarray]:
    """First position in ``bvh.order`` and triangle count of every node's subtree, asserting that
    a right subtree's triangles follow its left sibling's."""
    nodes = bvh.nodes
    leaf = (nodes[:, 7] & LEAF_FLAG) != 0
    a = nodes[:, 3].astype(np.int64)
    first = np.where(leaf, a, -1)
    count = np.where(leaf, nodes[:, 7].astype(np.int64) & (LEAF_FLAG - 1), 0)
    for i in np.flatnonzero(~leaf)[::-1]:  # pre-order: children come after their parent
        assert first[a[i]] == first[i + 1] + count[i + 1]
        first[i], count[i] = first[i + 1], count[i + 1] + count[a[i]]
    return first, count


def _check_median_tree(bvh, tris: np.ndarray, max_leaf: int) -> None:
    """Every node splits iff it holds more than ``max_leaf`` triangles, into floor(c / 2) left and
    the rest right, at the object median of its longest centroid axis (centroids summed in
    float64, compared rounded to float32, as documented in bvh_median)."""
    first, count = _node_ranges(bvh)
    leaf = (bvh.nodes[:, 7] & LEAF_FLAG) != 0
    assert (count[leaf] <= max_leaf).all() and (count[~leaf] > max_leaf).all()
    assert bvh.depth == depth_bound(len(tris), max_leaf)
    t = tris[bvh.order]
    cen = ((t[:, 0].astype(np.float64) + t[:, 1] + t[:, 2]) / 3.0).astype(np.float32)
    for i in np.flatnonzero(~leaf):
        c, s, k = count[i], first[i], int(bvh.nodes[i, 7])
        assert count[i + 1] == c // 2, f"node {i}: left child {count[i + 1]} of {c}"
        node_cen = cen[s:s + c]
        extent = node_cen.max(axis=0) - node_cen.min(axis=0)
        assert extent[k] == extent.max(), f"node {i}: axis {k}, extents {extent}"
        assert node_cen[:c // 2, k].max() <= node_cen[c // 2:, k].min(), f"node {i}: not a median split"


@pytest.mark.parametrize("n_tris, max_leaf", [(1, 4), (2, 1), (5, 4), (9, 4), (1000, 1), (3001, 4), (20_000, 7)])
def test_plain_median_tree_structure(n_tris, max_leaf):
    tris = random_triangles(np.random.default_rng(n_tris + 13 * max_leaf), n_tris)
    tris[:, :, 2] *= 3.0  # a longest axis at the top, mixed axes below
    bvh = build_median_bvh(tris, max_leaf=max_leaf, sah=False)
    check_invariants(bvh, tris, max_leaf)
    _check_median_tree(bvh, tris, max_leaf)
    if n_tris > 2 * max_leaf:
        assert bvh.nodes[0, 7] == 2  # root split on z


def test_plain_median_tree_with_ties_and_float32_input():
    # 9 distinct triangles repeated: most splits cut through runs of equal centroids.
    base = random_triangles(np.random.default_rng(2), 9).astype(np.float32)
    tris = np.tile(base, (1111, 1, 1))
    bvh = build_median_bvh(tris, max_leaf=4, sah=False)
    check_invariants(bvh, tris.astype(np.float64), 4)
    _check_median_tree(bvh, tris, 4)
    again = build_median_bvh(tris.copy(), max_leaf=4, sah=False)
    assert np.array_equal(bvh.nodes, again.nodes) and np.array_equal(bvh.order, again.order)


def test_plain_median_tree_closest_hits_match_brute_force():
    rng = np.random.default_rng(4)
    tris = random_triangles(rng, 3000, size=0.05)
    bvh = build_bvh(tris, max_leaf=4, sah=False)
    lo, hi = tris.min(axis=(0, 1)), tris.max(axis=(0, 1))
    origins = lo + rng.random((2000, 3)) * (hi - lo)
    assert_same_hits(bvh, tris, origins, rng.standard_normal((2000, 3)), min_hit_fraction=0.3)


def test_rows_split_on_several_threads_give_the_one_thread_tree(monkeypatch):
    """Chunks of a level's rows run on the pool (bvh_median._split_rows): the same nodes and order
    as in one thread, for widths that split evenly and unevenly and for a block of equal
    centroids (axis 0 everywhere), and the tree is still a median tree."""
    from mcpt import parallel
    from mcpt.shapes import bvh_median

    monkeypatch.setattr(bvh_median, "_PARALLEL_MIN", 64)  # chunk even small levels
    rng = np.random.default_rng(4)
    cases = [random_triangles(rng, 6001), random_triangles(rng, 4096),
             np.repeat(random_triangles(rng, 1), 3000, axis=0)]
    for tris in cases:
        built = {}
        for threads in ("1", "3"):
            monkeypatch.setenv("MCPT_THREADS", threads)
            monkeypatch.setattr(parallel, "_POOL", None)
            built[threads] = build_median_bvh(tris, max_leaf=4, sah=False)
        assert np.array_equal(built["1"].nodes, built["3"].nodes)
        assert np.array_equal(built["1"].order, built["3"].order)
        _check_median_tree(built["3"], tris, 4)

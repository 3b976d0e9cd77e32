"""BVH build invariants, the packed GPU layout, and closest hits against brute force."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mcpt.shapes.bvh_build as bvh_mod
from mcpt.shapes.bvh import LEAF_FLAG, MAX_STACK
from mcpt.shapes.bvh_build import build_bvh
from mcpt.shapes.mesh import load_mesh

from .conftest import BUNNY, CORNELL, bunny_reference
from .merge import merge_meshes
from .oracles import brute_force_closest_hit, bvh_closest_hit


@pytest.fixture(scope="module")
def bunny_tris() -> np.ndarray:
    return load_mesh(BUNNY).triangles()


@pytest.fixture(scope="module")
def bunny_bvh(bunny_tris):
    return build_bvh(bunny_tris)


def random_triangles(rng: np.random.Generator, n: int, size: float = 0.01) -> np.ndarray:
    """n small triangles scattered in the unit cube, (n, 3, 3) float64."""
    return rng.random((n, 1, 3)) + size * rng.standard_normal((n, 3, 3))


def depth_bound(n_tris: int, max_leaf: int) -> int:
    return 1 if n_tris <= max_leaf else math.ceil(math.log2(n_tris / max_leaf)) + 1


def check_invariants(bvh, tris: np.ndarray, max_leaf: int) -> None:
    """Assert every structural property the GLSL traversal relies on."""
    nodes = bvh.nodes
    n_tris = len(tris)
    n_nodes = len(nodes)
    assert nodes.dtype == np.uint32 and nodes.shape == (n_nodes, 8)
    assert np.array_equal(np.sort(bvh.order), np.arange(n_tris)), "order is not a permutation"

    leaf = (nodes[:, 7] & LEAF_FLAG) != 0
    a = nodes[:, 3].astype(np.int64)
    b = nodes[:, 7].astype(np.int64)
    count = b & (LEAF_FLAG - 1)
    lo = nodes[:, 0:3].view(np.float32)
    hi = nodes[:, 4:7].view(np.float32)

    # Depth-first pre-order: walking "left = i + 1, right = a" must visit 0, 1, 2, ... in turn.
    visit, stack, depth_of = [], [(0, 1)], np.zeros(n_nodes, np.int64)
    while stack:
        i, depth = stack.pop()
        visit.append(i)
        depth_of[i] = depth
        if not leaf[i]:
            assert b[i] in (0, 1, 2), f"node {i}: split axis {b[i]}"
            assert a[i] > i + 1, f"node {i}: right child {a[i]} not after the left one"
            stack.append((int(a[i]), depth + 1))
            stack.append((i + 1, depth + 1))
    assert visit == list(range(n_nodes)), "nodes are not in depth-first pre-order"
    assert bvh.depth == depth_of.max()
    # SAH may split below the cap down to single triangles; + 1: the large-triangle subtree.
    assert bvh.depth <= depth_bound(n_tris, 1) + 1
    assert bvh.depth + 2 <= MAX_STACK

    # Leaves: sizes 1..max_leaf, ranges partition [0, F).
    first, cnt = a[leaf], count[leaf]
    assert cnt.min() >= 1 and cnt.max() <= max_leaf
    srt = np.argsort(first)
    ends = first[srt] + cnt[srt]
    assert first[srt][0] == 0 and ends[-1] == n_tris
    assert np.array_equal(first[srt][1:], ends[:-1]), "leaf ranges overlap or leave gaps"

    # Children inside parents (exactly, in float32).
    inner = np.flatnonzero(~leaf)
    for child in (inner + 1, a[inner]):
        assert (lo[child] >= lo[inner]).all() and (hi[child] <= hi[inner]).all()

    # Leaf boxes contain their triangles' float32 vertices (and the float64 ones).
    leaf_ids = np.flatnonzero(leaf)
    owner = np.repeat(leaf_ids, cnt)  # leaf of each reordered triangle, in leaf order
    tri_pos = np.arange(cnt.sum()) + np.repeat(first - (np.cumsum(cnt) - cnt), cnt)  # same order
    reordered = tris[bvh.order][tri_pos]
    for corners in (reordered.astype(np.float32), reordered.astype(np.float64)):
        assert (corners >= lo[owner][:, None, :]).all()
        assert (corners <= hi[owner][:, None, :]).all()


def test_bunny_invariants(bunny_tris, bunny_bvh):
    check_invariants(bunny_bvh, bunny_tris, 4)
    s = bunny_bvh.stats()
    assert s["triangles"] == len(bunny_tris) == 69451
    assert s["max_leaf_size"] <= 4 and s["leaves"] * 2 - 1 == s["nodes"]
    assert set(s) == {"nodes", "leaves", "depth", "max_leaf_size", "mean_leaf_size", "build_seconds", "triangles",
                      "sah_cost"}


def test_bunny_builds_fast(bunny_tris):
    # Generous bound for a loaded CI machine; ~0.1 s when idle.
    assert build_bvh(bunny_tris).build_seconds < 2.0


@pytest.mark.parametrize("n_tris, max_leaf", [(1, 4), (2, 1), (5, 4), (17, 4), (1000, 1), (20_000, 4), (20_000, 7)])
def test_random_invariants(n_tris, max_leaf):
    tris = random_triangles(np.random.default_rng(n_tris * 31 + max_leaf), n_tris)
    check_invariants(build_bvh(tris, max_leaf=max_leaf), tris, max_leaf)


def test_float32_input_and_non_representable_coordinates():
    rng = np.random.default_rng(3)
    tris64 = 0.1 + 1e-3 * random_triangles(rng, 5000)  # values like 0.1 that float32 rounds
    check_invariants(build_bvh(tris64), tris64, 4)
    tris32 = tris64.astype(np.float32)
    bvh = build_bvh(tris32)
    check_invariants(bvh, tris32.astype(np.float64), 4)


def test_identical_centroids_still_split():
    # 100k copies of one triangle: no axis separates them, yet leaves must stay small.
    n = 100_000
    tris = np.broadcast_to(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), (n, 3, 3))
    bvh = build_bvh(tris)
    s = bvh.stats()
    assert s["max_leaf_size"] <= 4
    assert s["depth"] <= depth_bound(n, 4) == 16
    check_invariants(bvh, np.ascontiguousarray(tris), 4)


def test_split_follows_longest_centroid_axis():
    rng = np.random.default_rng(5)
    tris = random_triangles(rng, 4096)
    tris[:, :, 1] *= 10.0  # stretch along y
    bvh = build_bvh(tris)
    assert bvh.nodes[0, 7] == 1  # root split axis y
    right = int(bvh.nodes[0, 3])
    cy = tris[bvh.order].mean(axis=1)[:, 1]
    # Left subtree = reordered triangles [0, 2048), right = [2048, 4096): median split on y.
    assert right > 1
    assert cy[:2048].max() <= cy[2048:].min()


def test_deterministic():
    tris = random_triangles(np.random.default_rng(11), 3000)
    b1, b2 = build_bvh(tris), build_bvh(tris.copy())
    assert np.array_equal(b1.nodes, b2.nodes) and np.array_equal(b1.order, b2.order)


def test_empty_input_gives_missing_leaf():
    bvh = build_bvh(np.zeros((0, 3, 3)))
    assert bvh.num_nodes == 1 and bvh.depth == 1 and bvh.nodes[0, 7] == LEAF_FLAG
    t, i = bvh_closest_hit(bvh, np.zeros((0, 3, 3)), np.zeros((2, 3)), np.ones((2, 3)))
    assert np.isinf(t).all() and (i == -1).all()


def test_rejects_bad_input(monkeypatch):
    with pytest.raises(ValueError, match="shape"):
        build_bvh(np.zeros((4, 3)))
    bad = np.zeros((4, 3, 3))
    bad[2, 1, 0] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        build_bvh(bad)
    with pytest.raises(ValueError, match="max_leaf"):
        build_bvh(np.zeros((4, 3, 3)), max_leaf=0)
    # The stack guard: pretend the GPU stack were tiny.
    monkeypatch.setattr(bvh_mod, "MAX_STACK", 6)
    with pytest.raises(RuntimeError, match="MAX_STACK"):
        build_bvh(random_triangles(np.random.default_rng(0), 1000))


def test_stack_size_is_plenty():
    # ceil(log2(2^60 / 4)) + 1 + 2 = 61 <= 64
    assert depth_bound(2**60, 4) + 2 <= MAX_STACK


def rays_at_box(rng, lo, hi, n):
    """Rays from a sphere around [lo, hi] towards random points inside it."""
    center, radius = (lo + hi) / 2, np.linalg.norm(hi - lo)
    u = rng.standard_normal((n, 3))
    origins = center + radius * u / np.linalg.norm(u, axis=1, keepdims=True)
    return origins, lo + rng.random((n, 3)) * (hi - lo) - origins


def assert_same_hits(bvh, tris, origins, dirs, min_hit_fraction):
    t_ref, i_ref = brute_force_closest_hit(tris, origins, dirs)
    t_bvh, i_bvh = bvh_closest_hit(bvh, tris[bvh.order], origins, dirs)
    i_bvh_orig = np.where(i_bvh >= 0, bvh.order[np.maximum(i_bvh, 0)], -1)
    hit = i_ref >= 0
    assert hit.mean() >= min_hit_fraction
    assert np.array_equal(i_bvh_orig, i_ref), f"{(i_bvh_orig != i_ref).sum()} rays disagree"
    assert np.isinf(t_bvh[~hit]).all()
    np.testing.assert_allclose(t_bvh[hit], t_ref[hit], rtol=1e-6, atol=0)


def test_closest_hit_matches_brute_force_bunny():
    tris, bvh, origins, dirs, t_ref, i_ref = bunny_reference()
    t_bvh, i_bvh = bvh_closest_hit(bvh, tris[bvh.order], origins, dirs)
    i_bvh_orig = np.where(i_bvh >= 0, bvh.order[np.maximum(i_bvh, 0)], -1)
    hit = i_ref >= 0
    assert hit.mean() >= 0.5
    assert np.array_equal(i_bvh_orig, i_ref), f"{(i_bvh_orig != i_ref).sum()} rays disagree"
    assert np.isinf(t_bvh[~hit]).all()
    np.testing.assert_allclose(t_bvh[hit], t_ref[hit], rtol=1e-6, atol=0)


def test_closest_hit_flat_boxes_cornell():
    # Axis-aligned walls have zero-thickness boxes: the slab test must not lose their hits.
    meshes = [load_mesh(p) for p in sorted(CORNELL.glob("*.obj"))]
    tris = merge_meshes([(m, None) for m in meshes]).triangles()
    bvh = build_bvh(tris, max_leaf=1)
    rng = np.random.default_rng(1)
    lo, hi = tris.min(axis=(0, 1)), tris.max(axis=(0, 1))
    # From inside the box, so most rays hit a wall (the rest leave through the open front).
    origins = lo + (0.1 + 0.8 * rng.random((3000, 3))) * (hi - lo)
    dirs = rng.standard_normal((3000, 3))
    assert_same_hits(bvh, tris, origins, dirs, min_hit_fraction=0.7)
    # Axis-parallel rays (zero direction components) from outside.
    o2, d2 = rays_at_box(rng, lo, hi, 2000)
    axis = rng.integers(0, 3, 2000)
    d2 = np.zeros_like(d2)
    d2[np.arange(2000), axis] = -np.sign(o2[np.arange(2000), axis] - (lo + hi)[axis] / 2)
    assert_same_hits(bvh, tris, o2, d2, min_hit_fraction=0.0)


def test_brute_force_basic():
    tri = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                    [[0.0, 0.0, 2.0], [1.0, 0.0, 2.0], [0.0, 1.0, 2.0]]])
    o = np.array([[0.2, 0.2, 5.0], [0.2, 0.2, 1.0], [0.9, 0.9, 5.0], [0.2, 0.2, -1.0]])
    d = np.array([[0.0, 0.0, -2.0], [0.0, 0.0, -1.0], [0.0, 0.0, -1.0], [0.0, 0.0, -1.0]])
    t, i = brute_force_closest_hit(tri, o, d)
    np.testing.assert_allclose(t[:2], [1.5, 1.0])  # t in units of |dir|
    assert i.tolist() == [1, 0, -1, -1]
    assert np.isinf(t[2:]).all()


def test_large_triangles_get_their_own_subtree():
    # Room-sized walls among many small triangles: a pure median split would drag the walls'
    # extent into small leaves' boxes; build_bvh puts them under the root's right child.
    rng = np.random.default_rng(11)
    small = random_triangles(rng, 3000, size=0.01)
    walls = np.array([[[-5, -5, -5], [5, -5, -5], [5, 5, -5]], [[-5, -5, -5], [5, 5, -5], [-5, 5, -5]],
                      [[-5, -5, -5], [-5, 5, -5], [-5, 5, 5]], [[-5, -5, -5], [-5, 5, 5], [-5, -5, 5]]], float)
    tris = np.concatenate([small[:1500], walls, small[1500:]])
    bvh = build_bvh(tris)
    check_invariants(bvh, tris, 4)
    right = int(bvh.nodes[0, 3])
    # The root's right subtree holds exactly the four walls.
    first_wall = np.flatnonzero(np.isin(bvh.order, [1500, 1501, 1502, 1503]))
    assert sorted(bvh.order[first_wall].tolist()) == [1500, 1501, 1502, 1503]
    assert first_wall.min() == 3000 and first_wall.max() == 3003
    assert right > 1 and bvh.bounds_max[1].max() < 1.5  # the small subtree's box stays small
    origins = rng.uniform(-4, 4, (2000, 3))
    dirs = rng.normal(size=(2000, 3))
    t_ref, i_ref = brute_force_closest_hit(tris, origins, dirs)
    t_bvh, i_bvh = bvh_closest_hit(bvh, tris[bvh.order], origins, dirs)
    assert np.array_equal(np.where(i_bvh >= 0, bvh.order[np.maximum(i_bvh, 0)], -1), i_ref)


def test_gpu_boxes_are_grown_strictly_outward_and_empty_ones_stay_empty():
    """The GPU layouts grow each box (bvh.grown_boxes) so a ray along a box face starts strictly
    inside the slab: at coordinates 0, tiny and huge, each bound moves out, never in."""
    from mcpt.shapes.bvh import GPU_BOX_FLOOR, GPU_BOX_GROWTH, grown_boxes

    lo = np.array([[0.0, -1e-30, 555.0], [-3.0e7, 1.0, -0.0], [np.inf, np.inf, np.inf]], np.float32)
    hi = np.array([[0.0, 1e-30, 555.0], [3.0e7, 1.0, 0.0], [-np.inf, -np.inf, -np.inf]], np.float32)
    glo, ghi = grown_boxes(lo, hi, extent=555.0)
    assert glo.dtype == ghi.dtype == np.float32
    assert (glo[:2] < lo[:2]).all() and (ghi[:2] > hi[:2]).all()
    # at least GPU_BOX_FLOOR * extent out, so 1e30 (the shader's 1 / 0) times it is out of reach
    assert (lo[:2] - glo[:2] >= 0.99 * GPU_BOX_FLOOR * 555.0).all()
    assert (ghi[:2] - hi[:2] >= 0.99 * GPU_BOX_FLOOR * 555.0).all()
    # and no more than a few ulps of the coordinate where it is large: boxes stay tight
    assert lo[1, 0] - glo[1, 0] <= 4 * GPU_BOX_GROWTH * 3.0e7
    assert np.isposinf(glo[2]).all() and np.isneginf(ghi[2]).all()  # the empty box's values stay

"""Test oracles: float64 CPU ray-triangle intersection, brute force and through a BVH.

The GPU traversal (glsl/bvh.glsl) is checked against these (tests/test_bvh.py, test_bvh_gpu.py)."""

from __future__ import annotations

import numpy as np

from mcpt.shapes.bvh import BVH, LEAF_FLAG, MAX_STACK

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

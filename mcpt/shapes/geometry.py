"""Triangles as glsl/geometry.glsl reads them: three RGBA32UI texels per triangle.

    texel 3i + k = (corner k as float32 bits, material id for k = 0 else 0)
"""

from __future__ import annotations

import numpy as np

from ..parallel import ordered, row_chunks


def column_bounds(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi): the minimum and maximum of every column of an (N, k) array (N >= 1). A column at
    a time: min/max over axis 0 of an (N, 3) array is 5x slower (0.039 against 0.007 s at
    5 * 10^5 vertices, issue #23)."""
    return (np.array([a[:, j].min() for j in range(a.shape[1])]),
            np.array([a[:, j].max() for j in range(a.shape[1])]))


def pack_triangles(tris: np.ndarray, tri_material: np.ndarray) -> np.ndarray:
    """Three RGBA32UI texels per triangle: (v0 bits, material), (v1 bits, 0), (v2 bits, 0)."""
    f = tris.shape[0]
    bits = np.ascontiguousarray(tris, np.float32).view(np.uint32)
    material = np.broadcast_to(np.asarray(tri_material, np.uint32), (f,))
    out = np.empty((f, 3, 4), np.uint32)

    def fill(rows: slice) -> None:  # triangle by triangle: a chunk per core (issue #23: 48 MB at 10^6)
        out[rows, :, :3] = bits[rows]
        out[rows, 0, 3] = material[rows]
        out[rows, 1:, 3] = 0

    ordered(fill, row_chunks(f))
    return out.reshape(-1, 4)


def areas(tris: np.ndarray) -> np.ndarray:
    """(F,) float64 areas of (F, 3, 3) triangles (world units squared)."""
    e1 = tris[:, 1].astype(np.float64) - tris[:, 0]
    e2 = tris[:, 2].astype(np.float64) - tris[:, 0]
    return 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)


def shared_vertices(tris: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct corners of (F, 3, 3) triangles, equal when their float32 bits are equal.

    Returns (addr, ids): ``addr[j]`` the texel of pack_triangles' layout (3 i + k) where distinct
    vertex j first appears, ``ids`` (F, 3) each corner's distinct-vertex index. glsl/bvh.glsl
    shears each distinct vertex once per ray in small scenes.
    """
    bits = np.ascontiguousarray(tris, np.float32).view(np.uint32).reshape(-1, 3)
    _, first, ids = np.unique(bits, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)                 # number the vertices by first appearance
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return first[order].astype(np.int64), rank[ids.reshape(-1)].reshape(-1, 3).astype(np.int64)


def vertex_bits(tris: np.ndarray, addr: np.ndarray) -> tuple[int, ...]:
    """The float32 bits (x, y, z, ...) of the corners at texels ``addr`` (:func:`shared_vertices`)
    of (F, 3, 3) triangles: glsl/bvh.glsl compiles them in rather than fetching them (issue #23)."""
    bits = np.ascontiguousarray(tris, np.float32).view(np.uint32).reshape(-1, 3)
    return tuple(int(b) for b in bits[np.asarray(addr, np.int64)].ravel())


def shared_edges(ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct undirected edges of triangles given as (F, 3) distinct-vertex ids
    (:func:`shared_vertices`), for glsl/bvh.glsl's once-per-ray edge functions (issue #23).

    The watertight test (Woop et al. 2013) of triangle (A, B, C) uses the edge functions
    U = e(C, B), V = e(A, C), W = e(B, A) of its sheared vertices, e(P, Q) = P.x Q.y - P.y Q.x;
    e(Q, P) is exactly -e(P, Q) (the same two products, subtracted the other way round), so an edge
    shared by two triangles is computed once per ray. Returns (verts, signed): ``verts`` (E, 2) each
    edge's vertex ids (lo <= hi; numbered by first appearance), ``signed`` (F, 3) for U, V, W of each
    triangle the edge index k meaning +e(lo, hi), or ~k (= -k - 1) meaning -e(lo, hi).
    """
    ids = np.asarray(ids, np.int64).reshape(-1, 3)
    p = ids[:, [2, 0, 1]].ravel()             # U = e(C, B), V = e(A, C), W = e(B, A)
    q = ids[:, [1, 2, 0]].ravel()
    lo, hi = np.minimum(p, q), np.maximum(p, q)
    pairs = np.stack([lo, hi], axis=1)
    if not len(pairs):
        return np.zeros((0, 2), np.int64), np.zeros((0, 3), np.int64)
    _, first, inv = np.unique(pairs, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)                 # number the edges by first appearance
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    k = rank[inv.reshape(-1)]
    signed = np.where(p <= q, k, ~k).reshape(-1, 3)
    return pairs[first[order]], signed.astype(np.int64)

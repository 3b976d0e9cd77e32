"""Triangles as glsl/geometry.glsl reads them: three RGBA32UI texels per triangle.

    texel 3i + k = (corner k as float32 bits, material id for k = 0 else 0)
"""

from __future__ import annotations

import numpy as np


def pack_triangles(tris: np.ndarray, tri_material: np.ndarray) -> np.ndarray:
    """Three RGBA32UI texels per triangle: (v0 bits, material), (v1 bits, 0), (v2 bits, 0)."""
    f = tris.shape[0]
    out = np.zeros((f, 3, 4), np.uint32)
    out[:, :, :3] = np.ascontiguousarray(tris, np.float32).view(np.uint32)
    out[:, 0, 3] = tri_material
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

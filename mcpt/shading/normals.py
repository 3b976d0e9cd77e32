"""Smooth shading normals: corner normals packed for glsl/normals.glsl.

    normals   1 RGBA32UI texel per triangle: the three corner normals, octahedral-encoded as two
              16-bit snorms each (error < 0.004 degrees), 4th component 0
"""

from __future__ import annotations

import numpy as np


def octahedral_encode(n: np.ndarray) -> np.ndarray:
    """Unit vectors (..., 3) -> uint32: octahedral map (Cigolle et al. 2014, JCGT 3(2)) with two
    16-bit snorms, x in the low half (GLSL unpackSnorm2x16)."""
    n = np.asarray(n, np.float64)
    p = n[..., :2] / np.maximum(np.abs(n).sum(axis=-1, keepdims=True), 1e-30)
    folded = (1.0 - np.abs(p[..., ::-1])) * np.where(p >= 0.0, 1.0, -1.0)
    p = np.where(n[..., 2:3] < 0.0, folded, p)
    q = np.round(np.clip(p, -1.0, 1.0) * 32767.0).astype(np.int32) & 0xFFFF
    return (q[..., 0] | (q[..., 1] << 16)).astype(np.uint32)


def octahedral_decode(v: np.ndarray) -> np.ndarray:
    """The inverse (float64), as glsl/normals.glsl computes it."""
    v = np.asarray(v, np.uint32)
    q = np.stack([v & 0xFFFF, v >> 16], axis=-1).astype(np.uint16).view(np.int16)
    p = np.maximum(q.astype(np.float64) / 32767.0, -1.0)
    n = np.concatenate([p, 1.0 - np.abs(p).sum(axis=-1, keepdims=True)], axis=-1)
    t = np.maximum(-n[..., 2:3], 0.0)
    n[..., :2] += np.where(n[..., :2] >= 0.0, -t, t)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def pack_normals(normals: np.ndarray) -> np.ndarray:
    """One RGBA32UI texel per triangle: the three corner normals octahedral-encoded, then 0."""
    out = np.zeros((normals.shape[0], 4), np.uint32)
    out[:, :3] = octahedral_encode(normals)
    return out


def unit_vertex_normals(normals: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Renormalise vertex normals; zero / non-finite ones (a source without normals: readers leave
    zeros) are generated as Mitsuba 3 generates them (src/render/mesh.cpp, Mesh::recompute_normals):
    each face's unit normal summed into its corners weighted by the corner's interior angle
    (Thuermer & Wuethrich, "Computing Vertex Normals from Polygonal Facets", JGT 3(1), 1998), on
    the world-space positions of the non-degenerate triangles. The same file then shades the same
    in mcpt and in Mitsuba (area or unweighted averages differ visibly on coarse meshes).
    """
    length = np.linalg.norm(normals, axis=1)
    broken = ~(np.isfinite(length) & (length > 0))
    out = normals / np.where(broken, 1.0, length)[:, None]
    if broken.any():
        acc = angle_weighted_normals(vertices, faces)[broken]
        acc_len = np.linalg.norm(acc, axis=1)
        fixed = np.zeros((int(broken.sum()), 3))
        ok = acc_len > 0
        fixed[ok] = acc[ok] / acc_len[ok, None]
        out[broken] = fixed  # still zero only for vertices no triangle uses
    return out


def angle_weighted_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(V, 3) sums over the faces at each vertex of (unit face normal x interior angle there),
    not normalised (see :func:`unit_vertex_normals`)."""
    p = [vertices[faces[:, k]] for k in range(3)]
    n = np.cross(p[1] - p[0], p[2] - p[0])
    n_len = np.linalg.norm(n, axis=1)
    valid = n_len > 0
    n = n / np.where(valid, n_len, 1.0)[:, None]
    acc = np.zeros((len(vertices), 3))
    for k in range(3):
        e1, e2 = p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]
        cos = np.einsum("ij,ij->i", e1, e2) / np.maximum(
            np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1), 1e-300)
        w = np.where(valid, np.arccos(np.clip(cos, -1.0, 1.0)), 0.0)
        for c in range(3):
            acc[:, c] += np.bincount(faces[:, k], weights=n[:, c] * w, minlength=len(vertices))
    return acc

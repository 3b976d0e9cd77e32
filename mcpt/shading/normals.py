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
    """Renormalise vertex normals; zero / non-finite ones fall back to area-weighted face normals.

    Assimp leaves a zero normal where all adjacent faces were degenerate or the file gave a
    broken one; a zero normal would turn into NaN in the shader's normalize().
    """
    length = np.linalg.norm(normals, axis=1)
    broken = ~(np.isfinite(length) & (length > 0))
    out = normals / np.where(broken, 1.0, length)[:, None]
    if broken.any():
        a, b, c = (vertices[faces[:, k]] for k in range(3))
        face_n = np.cross(b - a, c - a)  # length = 2 * area, so the sum is area weighted
        acc = np.zeros_like(vertices)
        for k in range(3):
            np.add.at(acc, faces[:, k], face_n)
        acc_len = np.linalg.norm(acc[broken], axis=1)
        fixed = np.zeros((int(broken.sum()), 3))
        ok = acc_len > 0
        fixed[ok] = acc[broken][ok] / acc_len[ok, None]
        out[broken] = fixed  # still zero only for vertices no triangle uses
    return out

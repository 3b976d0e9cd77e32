"""Tangent-space normal maps (GLSL side: glsl/normal_map.glsl): per-vertex tangents and the two
buffers the shader reads.

    tangents     1 RGBA32UI texel per triangle (BVH order): the three corner tangents,
                 octahedral-encoded (mcpt/shading/normals.py), then per corner k: bit k set,
                 B = -N x T (handedness); bit k + 3 set, no tangent (degenerate UVs)
    normal_maps  1 RGBA32UI texel per material: (normal-map texture id or 0xffffffff, flags,
                 scale (float bits), 0); flags bit 0: B = N x T always (Mitsuba's frame),
                 bit 1: the texture is a bump (height) map (mcpt/shading/bump_map.py)

Tangents (:func:`vertex_tangents`) follow what MikkTSpace computes for a glTF / Blender bake on
the usual meshes: per face the direction of increasing u (dp/du) and of increasing v (dp/dv, v up:
the image's top), each corner's share weighted by the face's angle there, projected into the
vertex's tangent plane and summed; the handedness sign is whether dp/dv lies on the N x T side.
(MikkTSpace also splits vertices where the summed frames disagree; mcpt keeps the mesh's own
vertices.) Where a face's UVs are degenerate (zero UV area) it adds nothing; a vertex that gets
no tangent at all stores zero, and the shader then uses any tangent perpendicular to the normal
(only the normal map's x / y then lose their direction; a flat map still gives the normal).

The shader maps a texel c (linear, 8-bit) to n = normalize((2c - 1) * (scale, scale, 1)) (glTF's
normalTexture.scale) and the shading normal to n.x T + n.y B + n.z N, with T Gram-Schmidt
orthogonalised against N (Mitsuba's normalmap BSDF, src/bsdfs/normalmap.cpp, builds its frame the
same way from dp/du, with B = N x T).
"""

from __future__ import annotations

import numpy as np

from .bump_map import FLAG_BUMP  # a height map, not a normal map
from .normals import octahedral_encode
from .texture import TextureError

NO_MAP = 0xFFFFFFFF
FLAG_RIGHT_HANDED = 1     # B = N x T always (Mitsuba), not by the UVs' handedness (MikkTSpace)


def vertex_tangents(vertices: np.ndarray, faces: np.ndarray, uvs: np.ndarray,
                    normals: np.ndarray | None = None) -> np.ndarray:
    """(V, 4) float64: per vertex the unit tangent (dp/du in its tangent plane; 0 where no face
    with usable UVs touches it) and the handedness sign (+1: dp/dv on the N x T side)."""
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    uv = np.asarray(uvs, np.float64)
    p0, p1, p2 = (v[f[:, k]] for k in range(3))
    t0, t1, t2 = (uv[f[:, k]] for k in range(3))
    e1, e2 = p1 - p0, p2 - p0
    d1, d2 = t1 - t0, t2 - t0
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    ok = np.abs(det) > 1e-20 * np.maximum(1.0, np.abs(d1).max(axis=1) * np.abs(d2).max(axis=1))
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)[:, None]
    dpdu = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * inv
    dpdv = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * inv
    face_n = np.cross(e1, e2)
    if normals is None:  # area-weighted vertex normals (the frame the tangent is projected into)
        normals = np.zeros_like(v)
        for k in range(3):
            np.add.at(normals, f[:, k], face_n)
    n = np.asarray(normals, np.float64)
    n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    t_acc, b_acc = np.zeros_like(v), np.zeros_like(v)
    for k in range(3):
        a, b = (p1, p2) if k == 0 else ((p2, p0) if k == 1 else (p0, p1))
        c = (p0, p1, p2)[k]
        ea, eb = a - c, b - c
        cosang = np.einsum("ij,ij->i", ea, eb) / np.maximum(
            np.linalg.norm(ea, axis=1) * np.linalg.norm(eb, axis=1), 1e-30)
        w = np.arccos(np.clip(cosang, -1.0, 1.0))[:, None] * ok[:, None]
        tu = dpdu / np.maximum(np.linalg.norm(dpdu, axis=1, keepdims=True), 1e-30)
        tv = dpdv / np.maximum(np.linalg.norm(dpdv, axis=1, keepdims=True), 1e-30)
        np.add.at(t_acc, f[:, k], w * tu)
        np.add.at(b_acc, f[:, k], w * tv)
    t = t_acc - n * np.einsum("ij,ij->i", t_acc, n)[:, None]
    length = np.linalg.norm(t, axis=1, keepdims=True)
    t = np.where(length > 1e-12, t / np.maximum(length, 1e-30), 0.0)
    sign = np.where(np.einsum("ij,ij->i", np.cross(n, t), b_acc) < 0.0, -1.0, 1.0)
    return np.concatenate([t, sign[:, None]], axis=1)


def pack_tangents(corner_tangents: np.ndarray) -> np.ndarray:
    """One RGBA32UI texel per triangle from (F, 3, 4) corner tangents and signs."""
    t = np.asarray(corner_tangents, np.float64)
    out = np.zeros((t.shape[0], 4), np.uint32)
    zero = np.linalg.norm(t[..., :3], axis=-1) < 1e-12
    out[:, :3] = np.where(zero, 0, octahedral_encode(np.where(zero[..., None], 1.0, t[..., :3])))
    bits = (t[..., 3] < 0.0).astype(np.uint32) | (zero.astype(np.uint32) << 3)
    out[:, 3] = bits[:, 0] | (bits[:, 1] << 1) | (bits[:, 2] << 2)
    return out


def pack_normal_maps(normal_map: tuple, opacity: tuple | None = None) -> np.ndarray:
    """One RGBA32UI texel per material from the table's ``normal_map`` column ((texture id,
    scale, right_handed, bump) or None) and ``opacity`` column ((texture id, cutoff or None) or
    None: mcpt/shading/opacity.py)."""
    from .opacity import opacity_bits

    out = np.zeros((max(len(normal_map), 1), 4), np.uint32)
    out[:, 0] = NO_MAP
    out[:, 3] = NO_MAP
    for i, nm in enumerate(normal_map):
        if nm is not None:
            tex, scale, right, bump = nm
            flags = (FLAG_RIGHT_HANDED if right else 0) | (FLAG_BUMP if bump else 0)
            out[i, :3] = (tex, flags, np.float32(scale).view(np.uint32))
    for i, op in enumerate(opacity or ()):
        if op is not None:
            out[i, 3] = op[0]
            out[i, 1] |= np.uint32(opacity_bits(op[1]))
    return out


def check_normal_map(texture) -> None:
    """Refuse an image that is no tangent-space normal map: a grey (one-channel) image, or one
    whose texels do not decode to unit vectors pointing out of the surface (an sRGB-encoded or
    height image read as linear gives median |2c - 1| far from 1 or z <= 0)."""
    rgb = texture.decoded().reshape(-1, 3)  # c / 255, or a float texture's values (issue #22)
    if (rgb[:, 0] == rgb[:, 1]).all() and (rgb[:, 1] == rgb[:, 2]).all():
        raise TextureError(f"{texture.path}: one channel (grey): a normal map needs "
                           "x, y, z in R, G, B (a height map is a bump map)")
    n = rgb * 2.0 - 1.0
    length = np.median(np.linalg.norm(n, axis=1))
    if not 0.85 <= length <= 1.15 or np.median(n[:, 2]) <= 0.0:
        raise TextureError(f"{texture.path}: not a tangent-space normal map (median "
                           f"|2c - 1| = {length:.2f}, median z = {np.median(n[:, 2]):.2f}; "
                           "expected ~1 and > 0: an sRGB-encoded or height image?)")

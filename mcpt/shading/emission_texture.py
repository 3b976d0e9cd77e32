"""Emission textures (issue #22; GLSL side: glsl/emission_texture.glsl).

An emitter's radiance at a point is ``texture(uv) x emission`` (the material's ``emission`` is a
scale; the texture is sRGB-decoded like an albedo texture). Next-event estimation picks each
emissive triangle with probability proportional to its actual power -- the integral of the
emitted luminance over the triangle, ``mean luminance x area`` -- and samples a point on it
uniformly by area, so its area density is ``pmf / area`` PER TRIANGLE. BSDF-sampled rays that hit
an emitter need that same density for the MIS weight (Veach 1997, sec. 9.2): the ``emit_pdf``
buffer holds it, one float32 per triangle in BVH order, 4 a texel (0: not an emitter).

The mean luminance over a triangle is a quadrature on the shader's own lookup (texture.lookup):
the centroids of the s^2 congruent sub-triangles of a uniform subdivision, s growing with the
number of texels the triangle's UVs cover (about 16 points per texel, s <= 128). Any positive
power keeps the estimator unbiased -- both strategies read the same table -- so the quadrature
only has to be close for low variance; a floor of 1e-3 x the texture's mean keeps every
triangle of an emitting material pickable, so NEE alone still finds light the quadrature missed.
The Uses field: ``emission_textures`` (MCPT_EMISSION_TEXTURES), only when some used material has one.
"""

from __future__ import annotations

import numpy as np

from .lights import LUMINANCE
from .texture import apply_uv, lookup

MAX_SUBDIVISION = 128
FLOOR = 1e-3  # fraction of the texture's mean luminance every triangle keeps (module docstring)
CHUNK = 1 << 20  # lookups per batch (memory)


def subdivision_points(s: int) -> np.ndarray:
    """(s^2, 2) barycentrics (b1, b2) of the centroids of the s^2 congruent sub-triangles."""
    i, j = np.meshgrid(np.arange(s), np.arange(s), indexing="ij")
    up = (i + j) < s
    down = (i + j) < s - 1
    pts = [np.stack([(i[up] + 1 / 3) / s, (j[up] + 1 / 3) / s], 1),
           np.stack([(i[down] + 2 / 3) / s, (j[down] + 2 / 3) / s], 1)]
    return np.concatenate(pts)


def texel_area(texture, uvs: np.ndarray) -> np.ndarray:
    """(F,) the number of texels each UV triangle (F, 3, 2) covers (after the texture's UV map)."""
    t = apply_uv(getattr(texture, "uv", ((1, 0, 0), (0, 1, 0))), uvs.reshape(-1, 2)).reshape(-1, 3, 2)
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    size = getattr(texture, "width", 1) * getattr(texture, "height", 1)
    return 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) * size


def mean_luminance(texture, uvs: np.ndarray, weights=LUMINANCE) -> np.ndarray:
    """(F,) the mean of ``texture . weights`` (RGB weights: luminance x the emission scale) over
    each UV triangle (F, 3, 2), by quadrature."""
    uvs = np.asarray(uvs, np.float64)
    s = np.clip(np.ceil(4.0 * np.sqrt(texel_area(texture, uvs))), 2, MAX_SUBDIVISION).astype(np.int64)
    out = np.zeros(len(uvs))
    for level in np.unique(s):
        idx = np.nonzero(s == level)[0]
        b = subdivision_points(int(level))
        w = np.stack([1.0 - b.sum(1), b[:, 0], b[:, 1]], 1)  # (P, 3) corner weights
        step = max(1, CHUNK // len(b))
        for k in range(0, idx.size, step):
            tri = idx[k:k + step]
            pts = np.einsum("pc,fcd->fpd", w, uvs[tri]).reshape(-1, 2)
            out[tri] = (lookup(texture, pts) @ weights).reshape(len(tri), -1).mean(1)
    return out


def triangle_powers(areas: np.ndarray, tri_material: np.ndarray, uvs: np.ndarray, materials,
                    textures: list) -> np.ndarray:
    """(F,) each triangle's emitted power ``mean luminance(Le) x area`` (mcpt/shading/lights.py
    units): the texture's integral for textured emitters, luminance(emission) x area otherwise."""
    power = (materials.emission[tri_material] @ LUMINANCE) * areas
    for mid in np.unique(tri_material):
        tid = int(materials.emission_texture[mid])
        if tid < 0:
            continue
        sel = np.nonzero(tri_material == mid)[0]
        mean = mean_luminance(textures[tid], uvs[sel], LUMINANCE * materials.emission[mid])
        floor = FLOOR * float(np.sum(mean * areas[sel]) / max(np.sum(areas[sel]), 1e-300))
        power[sel] = np.maximum(mean, floor) * areas[sel]
    return power


def pack_emit_pdf(lights, n_triangles: int) -> np.ndarray:
    """The ``emit_pdf`` buffer: pmf / area of each triangle's light entry, 4 float32 a texel."""
    pdf = np.zeros(4 * max(1, -(-n_triangles // 4)), np.float32)
    a = lights.count
    if a:
        pdf[lights.triangles] = lights.pmf[:a] / lights.areas
    return pdf.view(np.uint32).reshape(-1, 4)


def uses(materials, ids) -> dict:
    """The Uses field: some used material's emission is a texture."""
    used = materials.used(ids)
    return {"emission_textures": any(materials.emission_texture[i] >= 0 for i in used)}

"""Emissive triangles for next-event estimation (GLSL side: glsl/lights.glsl).

Every emissive triangle is a light, picked with probability proportional to its emitted power
(luminance(Le) x area; the pi of a Lambertian emitter cancels) -- the thesis sampled a single
light triangle. One RGBA32UI texel per light: (triangle index, cdf upper bound, pmf, 0).
With a point sampled uniformly on the chosen triangle, the density per unit area is
``pmf / area = luminance(Le) / total power`` for every light: a per-MATERIAL constant that the
material table carries for MIS (mcpt/shading/materials.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709 / sRGB primaries


@dataclass(frozen=True)
class Lights:
    triangles: np.ndarray   # (L,) int: triangle index (BVH order) of each light
    pmf: np.ndarray         # (L,) float64, sums to 1
    total_power: float      # sum of luminance(Le) * area, W-like units (radiance x m^2)

    @property
    def count(self) -> int:
        return int(self.triangles.size)

    def pack(self) -> np.ndarray:
        out = np.zeros((max(self.count, 1), 4), np.uint32)
        if self.count:
            cdf = np.cumsum(self.pmf)
            cdf /= cdf[-1]
            cdf[-1] = np.inf  # u < 1 always lands in a bucket despite rounding
            out[: self.count, 0] = self.triangles
            out[: self.count, 1] = cdf.astype(np.float32).view(np.uint32)
            out[: self.count, 2] = self.pmf.astype(np.float32).view(np.uint32)
        return out


def build_lights(areas: np.ndarray, tri_emission: np.ndarray) -> Lights:
    """Lights from per-triangle areas (F,) and emitted radiance (F, 3) (triangles in BVH order)."""
    power = (tri_emission @ LUMINANCE) * areas
    idx = np.nonzero(power > 0.0)[0]
    total = float(power[idx].sum())
    pmf = power[idx] / total if total > 0 else np.zeros(0)
    return Lights(idx.astype(np.int64), pmf, total)


def material_light_pdf_area(emission: np.ndarray, total_power: float) -> np.ndarray:
    """luminance(Le) / total power per material (0 when the scene has no light)."""
    if total_power <= 0:
        return np.zeros(len(emission))
    return (np.asarray(emission, np.float64) @ LUMINANCE) / total_power

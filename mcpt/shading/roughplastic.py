"""Rough plastic (GLSL side: glsl/bsdf_roughplastic.glsl): Mitsuba 3's ``roughplastic``
(src/bsdfs/roughplastic.cpp), a diffuse base under a rough dielectric coat (microfacets of
mcpt/shading/microfacet.py):

    f cos = F D G2 / (4 cos_o)                                        (the coat's reflection)
          + A / (1 - K) * (1 / pi) / eta^2 * cos_i * T(cos_o) * T(cos_i)   (light through the coat)

with K = A Fdr_int (``nonlinear: true``) or Fdr_int (``false``, Mitsuba's default). T(mu) is the
coat's rough transmittance at incidence cosine mu, E_t(mu) = the integral of (1 - F) G1(wt) over
the visible normals of wi (Mitsuba's eval_transmittance), tabulated at Mitsuba's 64 cosines mu_k =
max(1e-6, k / 63) and read by linear interpolation as Mitsuba does; Fdr_int = 2 mean_k(E_r(mu_k;
1/eta) mu_k), the same 64-point mean of the inside reflectance E_r (eval_reflectance) Mitsuba
takes. The integrals are computed here in float64 over the half vector (Mitsuba: 32 x 32 or
128 x 128 Gauss-Legendre nodes over its visible-normal samples; the same integral).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from . import microfacet as MF
from .materials import fresnel_dielectric

RES = 64          # Mitsuba's MI_ROUGH_TRANSMITTANCE_RES
MU = np.maximum(1e-6, np.linspace(0.0, 1.0, RES))


def _coat(mu, eta: float, alpha: float, dist: str, n: int = 128) -> tuple[np.ndarray, np.ndarray]:
    """(E_r, E_t) of a rough interface for light arriving at cosines mu (any shape) from the side
    where the other side has relative index eta: the integrals of F G1(wr) and (1 - F) G1(wt) over
    the visible normals, D(h) G1(wo) max(0, wo.h) / wo.z, by quadrature over the half vector
    (theta_h = atan(alpha tan(pi v / 2)): dense where D is; wo in the xz plane: phi in (0, pi),
    doubled)."""
    mu = np.asarray(mu, np.float64)
    v = (np.arange(n) + 0.5) / n
    s = np.tan(0.5 * np.pi * v)
    th = np.arctan(alpha * s)
    dth = alpha * 0.5 * np.pi / np.cos(0.5 * np.pi * v) ** 2 / (1 + (alpha * s) ** 2) / n
    ph = (np.arange(n) + 0.5) / n * np.pi
    T, P = np.meshgrid(th, ph, indexing="ij")
    h = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1)  # (n, n, 3)
    m = mu.reshape(-1, 1, 1)
    o = np.stack(np.broadcast_arrays(np.sqrt(np.maximum(0.0, 1 - m * m)), 0.0 * m, m), -1)  # (M, 1, 1, 3)
    oh = (h * o).sum(-1)  # (M, n, n)
    lam = MF.LAMBDA[dist]
    vis = MF.D[dist](h, alpha) * np.maximum(oh, 0.0) / m / (1.0 + lam(o, alpha))
    F = fresnel_dielectric(np.clip(oh, 1e-12, 1.0), eta)
    r = 2 * oh[..., None] * h - o
    up = r[..., 2] > 0
    g_r = np.where(up, 1.0 / (1.0 + lam(np.where(up[..., None], r, h), alpha)), 0.0)
    # Refraction by h (Snell's law about the facet), eta = n_t / n_i.
    sin2_t = (1.0 - oh**2) / eta**2
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - sin2_t))
    t = (oh / eta - cos_t)[..., None] * h - o / eta
    down = (t[..., 2] < 0) & (sin2_t < 1)
    g_t = np.where(down, 1.0 / (1.0 + lam(np.where(down[..., None], t, -h), alpha)), 0.0)
    w = (np.sin(T) * dth[:, None]) * (2 * np.pi / n) * vis * (oh > 0)
    e_r, e_t = (w * F * g_r).sum((1, 2)), (w * (1 - F) * g_t).sum((1, 2))
    return e_r.reshape(mu.shape), e_t.reshape(mu.shape)


@lru_cache(maxsize=64)
def tables(eta: float, alpha: float, dist: str) -> tuple[np.ndarray, float]:
    """(T at the 64 cosines MU, Fdr_int) of a coat of relative index eta (inside / outside)."""
    t = _coat(MU, eta, alpha, dist)[1]
    r_in = _coat(MU, 1.0 / eta, alpha, dist)[0]
    return t, float(np.mean(r_in * MU) * 2.0)


def lerp(table: np.ndarray, mu) -> np.ndarray:
    """Mitsuba's lerp_gather: linear interpolation of the 64-entry table at cosine mu."""
    x = np.asarray(mu, np.float64) * (RES - 1)
    i = np.minimum(x.astype(np.int64), RES - 2)
    return table[i] + (table[i + 1] - table[i]) * (x - i)

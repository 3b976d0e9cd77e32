"""Rough dielectric interface (GLSL side: glsl/bsdf_roughdielectric.glsl): Walter et al. 2007,
"Microfacet Models for Refraction through Rough Surfaces", as Mitsuba 3's ``roughdielectric``
(src/bsdfs/roughdielectric.cpp). The table row uses the shared columns: ``alpha`` (texel 2.x),
``ior`` (2.y, the inside's index relative to the outside, air), the microfacet choices in the flags
(mcpt/shading/microfacet.py); the shader turns ``ior`` into n (other side) / n (this side) per hit.

:func:`bsdf` is the model in float64, written from the paper's equations (eqs. 20, 21 with the
1/eta^2 radiance scaling, Mitsuba's "missing term"): the tests' independent twin of the GLSL.
"""

from __future__ import annotations

import numpy as np

from . import microfacet as MF
from .materials import fresnel_dielectric

#: The least alpha a rough dielectric takes (below: use the smooth ``dielectric``).
MIN_ALPHA = 1e-3


def bsdf(wo: np.ndarray, wi: np.ndarray, eta: float, alpha: float, dist: str = "ggx",
         masking: str = "height_correlated") -> np.ndarray:
    """f |cos wi| for unit wo (wo.z > 0, the side of relative index ``eta`` = n_other / n_wo) and
    wi (N, 3) anywhere on the sphere; radiance transport (the refracted lobe carries 1/eta^2)."""
    wo = np.broadcast_to(np.asarray(wo, np.float64), wi.shape)
    refl = wi[:, 2] > 0
    h = wo + wi * np.where(refl, 1.0, eta)[:, None]
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    h *= np.sign(h[:, 2])[:, None]
    oh, ih = (wo * h).sum(1), (wi * h).sum(1)
    ok = (oh > 0) & (ih * wi[:, 2] > 0)
    lam = MF.LAMBDA[dist]
    dg = MF.D[dist](h, alpha) * MF.G2(lam(wo, alpha), lam(wi, alpha), masking)
    F = fresnel_dielectric(np.clip(oh, 1e-9, 1.0), eta)
    r = F * dg / (4 * wo[:, 2])
    t = (1 - F) * dg * np.abs(oh * ih) / (wo[:, 2] * (oh + eta * ih) ** 2)
    return np.where(ok, np.where(refl, r, t), 0.0)

"""The microfacet model of rough materials (GLSL side: glsl/bsdf_microfacet.glsl, with
glsl/bsdf_ggx.glsl and glsl/bsdf_beckmann.glsl): the distribution and the Smith masking term a
material chooses, their bits in the material flags, what a scene's choices compile, and float64
twins of the distributions (the tests' independent references).

``distribution``: ``ggx`` (Trowbridge-Reitz, default) or ``beckmann``. ``masking``:
``height_correlated`` (default; Heitz 2014, "Understanding the Masking-Shadowing Function", eq. 99:
G2 = 1 / (1 + Lambda(wo) + Lambda(wi))) or ``separable`` (G2 = G1(wo) G1(wi), Mitsuba 3's
MicrofacetDistribution::G, which the Mitsuba reader picks so that converted scenes match).
"""

from __future__ import annotations

import numpy as np

DISTRIBUTIONS = ("ggx", "beckmann")
MASKINGS = ("height_correlated", "separable")
FLAG_BECKMANN = 16     # material flags bit 4 (mcpt/shading/materials.py lists the others)
FLAG_SEPARABLE = 32    # bit 5


def flags(distribution: str, masking: str) -> int:
    """The flag bits of a rough material's choices."""
    return (FLAG_BECKMANN if distribution == "beckmann" else 0) | (FLAG_SEPARABLE if masking == "separable" else 0)


def uses(table, ids) -> dict[str, bool]:
    """The features.Uses fields the used rough materials need: the microfacet code (a rough
    conductor, dielectric or plastic), rough glass, rough plastic, Beckmann code, the separable term."""
    used = table.used(ids)
    rough = [i for i in used if table.is_rough(i)]
    return {"microfacet": bool(rough),
            "rough_dielectric": any(table.types[i] == "roughdielectric" for i in used),
            "rough_plastic": any(table.types[i] == "roughplastic" for i in used),
            "beckmann": any(table.distribution[i] == "beckmann" for i in rough),
            "separable_masking": any(table.masking[i] == "separable" for i in rough)}


def ggx_D(h: np.ndarray, a: float) -> np.ndarray:
    """GGX normal distribution (cos-weighted it integrates to 1 over the hemisphere)."""
    t2 = (h[..., 0] ** 2 + h[..., 1] ** 2) / a**2 + h[..., 2] ** 2
    return 1.0 / (np.pi * a**2 * t2**2)


def beckmann_D(h: np.ndarray, a: float) -> np.ndarray:
    """Beckmann: exp(-tan^2 / a^2) / (pi a^2 cos^4)."""
    c2 = h[..., 2] ** 2
    return np.exp(-(1.0 - c2) / c2 / a**2) / (np.pi * a**2 * c2**2)


def ggx_lambda(w: np.ndarray, a: float) -> np.ndarray:
    t2 = (w[..., 0] ** 2 + w[..., 1] ** 2) / w[..., 2] ** 2
    return 0.5 * (np.sqrt(1.0 + a**2 * t2) - 1.0)


def beckmann_lambda(w: np.ndarray, a: float) -> np.ndarray:
    """Walter et al. 2007's rational fit (eq. 27), which Mitsuba 3 evaluates."""
    b = np.abs(w[..., 2]) / (a * np.maximum(np.hypot(w[..., 0], w[..., 1]), 1e-300))
    c = np.minimum(b, 1.6)  # the fit is 0 from b = 1.6 on (normal incidence: b = inf)
    return np.where(b >= 1.6, 0.0, (1.0 - 1.259 * c + 0.396 * c * c) / (3.535 * c + 2.181 * c * c))


D = {"ggx": ggx_D, "beckmann": beckmann_D}
LAMBDA = {"ggx": ggx_lambda, "beckmann": beckmann_lambda}


def G2(lo: np.ndarray, li: np.ndarray, masking: str) -> np.ndarray:
    return 1.0 / ((1.0 + lo) * (1.0 + li)) if masking == "separable" else 1.0 / (1.0 + lo + li)

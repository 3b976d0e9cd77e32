"""glTF 2.0's metal-rough material (GLSL side: glsl/bsdf_metalrough.glsl), the BRDF of the glTF 2.0
specification's appendix B (B.3, "BRDF implementation"):

    f = mix(dielectric_brdf, metal_brdf, metallic)
    metal_brdf      = conductor_fresnel(f0 = baseColor, bsdf = specular_brdf(alpha))
    dielectric_brdf = fresnel_mix(ior = 1.5, base = diffuse_brdf(baseColor), layer = specular_brdf(alpha))

    specular_brdf(alpha) = D(h) V,  V = G2 / (4 |n.l| |n.v|)   (GGX D; Smith G2, mcpt/shading/microfacet.py)
    conductor_fresnel    = bsdf * (f0 + (1 - f0) (1 - |v.h|)^5)
    fresnel_mix          = mix(base, layer, F),  F = f0 + (1 - f0) (1 - |v.h|)^5,  f0 = ((1 - ior) / (1 + ior))^2

with alpha = roughness^2 (glTF's roughness is perceptual, B.3.2) and diffuse_brdf = baseColor / pi.

KHR_materials_ior (``ior``, default 1.5; >= 1, or 0: F0 = 1) and KHR_materials_specular
(``specular`` = specularFactor, default 1; ``specular_color`` = specularColorFactor, default
[1, 1, 1]) change the dielectric's fresnel_mix only, as the extensions' texts write it (issue #21
item 5):

    fresnel_mix(f0_color, ior, weight, base, layer):
        f0 = min(((1 - ior) / (1 + ior))^2 f0_color, 1);  fr = f0 + (1 - f0) (1 - |v.h|)^5
        = (1 - weight max(fr)) base + weight fr layer

i.e. F = F0 + (F90 - F0) (1 - |v.h|)^5 with F0 = min(f0(ior) specularColor, 1) specular and
F90 = specular (:func:`dielectric_f0_f90`), the base weighted by 1 - max(F.r, F.g, F.b); the metal
is unaffected. The table carries F0 (rgb) and F90 in texel 4, and the shader reads them only when
some used material differs from the defaults (MCPT_METALROUGH_SPECULAR): a scene without the
extensions compiles and renders exactly as before.
The table holds alpha (texel 2.x), baseColor (texel 0, or the albedo texture) and metallic (texel
3.x). alpha is floored at MIN_ALPHA (materials.py: below it GGX is too peaked for float32), so
roughness 0 renders as roughness ~0.03: the one approximation.
"""

from __future__ import annotations

import numpy as np

IOR = 1.5
F0 = ((1.0 - IOR) / (1.0 + IOR)) ** 2   # 0.04: the dielectric's Schlick f0 (B.3.4)
MIN_ALPHA = 1e-3                        # = materials.MIN_ALPHA (no import: materials imports this module)


DEFAULT_SPECULAR_COLOR = (1.0, 1.0, 1.0)


def dielectric_f0_f90(ior: float, specular: float = 1.0, color=DEFAULT_SPECULAR_COLOR) -> tuple[np.ndarray, float]:
    """KHR_materials_specular's dielectricSpecularF0 (rgb) and F90, with KHR_materials_ior's f0:
    F0 = min(((ior - 1) / (ior + 1))^2 specularColor, 1) specular, F90 = specular (ior 0: f0 1)."""
    f0 = ((float(ior) - 1.0) / (float(ior) + 1.0)) ** 2
    return np.minimum(f0 * np.asarray(color, np.float64), 1.0) * float(specular), float(specular)


def is_default(ior: float, specular: float, color) -> bool:
    """Whether a material is the plain appendix-B one (no KHR_materials_ior / _specular effect)."""
    return float(ior) == IOR and float(specular) == 1.0 and tuple(map(float, color)) == DEFAULT_SPECULAR_COLOR


def _schlick_w(c):
    return np.clip(1.0 - c, 0.0, 1.0) ** 5


def p_spec(base, metallic, f0, f90, cos_o) -> np.ndarray:
    """The probability of sampling the specular lobe at cos_o (glsl metalrough_p_spec): s / (s + d),
    s = mean of mix(F, Schlick(base), metallic), d = (1 - metallic) (1 - max(F)) mean(base)."""
    base, w = np.asarray(base, np.float64), _schlick_w(np.asarray(cos_o, np.float64))[..., None]
    fd = np.asarray(f0, np.float64) + (f90 - np.asarray(f0, np.float64)) * w
    fm = base + (1.0 - base) * w
    s = ((1.0 - metallic) * fd + metallic * fm).mean(-1)
    d = (1.0 - metallic) * (1.0 - fd.max(-1)) * base.mean()
    return np.where(s + d > 0.0, s / np.where(s + d > 0.0, s + d, 1.0), 1.0)


def eval_cos(base, metallic, a, f0, f90, wo, wi, masking="height_correlated"):
    """float64 twin of glsl metalrough_eval (GGX): f |cos_i| (N, 3) and the mixture pdf (N,) of unit
    directions wo, wi (N, 3) in the frame n = +z."""
    from .microfacet import G2, ggx_D, ggx_lambda

    base = np.asarray(base, np.float64)
    wo, wi = np.broadcast_arrays(np.asarray(wo, np.float64), np.asarray(wi, np.float64))
    ok = (wo[..., 2] > 0) & (wi[..., 2] > 0)
    h = wo + wi
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    oh = (wo * h).sum(-1)
    lo, li = ggx_lambda(wo, a), ggx_lambda(wi, a)
    d = ggx_D(h, a)
    spec = (d * G2(lo, li, masking) / (4.0 * wo[..., 2]))[..., None]
    w = _schlick_w(np.abs(oh))[..., None]
    fd = np.asarray(f0, np.float64) + (f90 - np.asarray(f0, np.float64)) * w
    fm = base + (1.0 - base) * w
    f = spec * ((1.0 - metallic) * fd + metallic * fm) \
        + (1.0 - metallic) * (1.0 - fd.max(-1, keepdims=True)) * base * wi[..., 2:3] / np.pi
    p = p_spec(base, metallic, f0, f90, wo[..., 2])
    pdf = p * d * (oh / (wo[..., 2] * (1.0 + lo))) / (4.0 * oh) + (1.0 - p) * wi[..., 2] / np.pi
    return np.where(ok[..., None], f, 0.0), np.where(ok, pdf, 0.0)


def alpha(roughness: float) -> float:
    """GGX alpha of a perceptual roughness in [0, 1] (alpha = roughness^2), floored at MIN_ALPHA."""
    return max(float(roughness) ** 2, MIN_ALPHA)


def uses(table, ids) -> dict[str, bool]:
    """The features.Uses fields: whether some used material is a metal-rough one, and whether one of
    them has KHR_materials_ior / _specular values other than the defaults."""
    rows = [i for i in table.used(ids) if table.types[i] == "metalrough"]
    return {"metalrough": bool(rows),
            "metalrough_specular": any(not is_default(table.ior[i], table.specular[i], table.specular_color[i])
                                       for i in rows)}


def pack(table, out: np.ndarray, fifth: bool) -> None:
    """Texel 3 of each metal-rough row: metallic, the metallic-roughness texture id (as a float, -1:
    none) and the perceptual roughness factor sqrt(alpha) (the texture's green scales it per texel)."""
    for i, t in enumerate(table.types):
        if t == "metalrough":
            row = [table.metallic[i], float(table.metal_rough[i]), np.sqrt(table.alpha[i])]
            out[i, 3, :3] = np.float32(row).view(np.uint32)
            out[i, 3, 3] = 0
            if fifth:  # texel 4: the dielectric's F0 (rgb), F90 (MCPT_METALROUGH_SPECULAR)
                f0, f90 = dielectric_f0_f90(table.ior[i], table.specular[i], table.specular_color[i])
                out[i, 4] = np.float32([*f0, f90]).view(np.uint32)

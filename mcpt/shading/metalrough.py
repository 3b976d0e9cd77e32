"""glTF 2.0's metal-rough material (GLSL side: glsl/bsdf_metalrough.glsl), the BRDF of the glTF 2.0
specification's appendix B (B.3, "BRDF implementation"):

    f = mix(dielectric_brdf, metal_brdf, metallic)
    metal_brdf      = conductor_fresnel(f0 = baseColor, bsdf = specular_brdf(alpha))
    dielectric_brdf = fresnel_mix(ior = 1.5, base = diffuse_brdf(baseColor), layer = specular_brdf(alpha))

    specular_brdf(alpha) = D(h) V,  V = G2 / (4 |n.l| |n.v|)   (GGX D; Smith G2, mcpt/shading/microfacet.py)
    conductor_fresnel    = bsdf * (f0 + (1 - f0) (1 - |v.h|)^5)
    fresnel_mix          = mix(base, layer, F),  F = f0 + (1 - f0) (1 - |v.h|)^5,  f0 = ((1 - ior) / (1 + ior))^2

with alpha = roughness^2 (glTF's roughness is perceptual, B.3.2) and diffuse_brdf = baseColor / pi.
The table holds alpha (texel 2.x), baseColor (texel 0, or the albedo texture) and metallic (texel
3.x). alpha is floored at MIN_ALPHA (materials.py: below it GGX is too peaked for float32), so
roughness 0 renders as roughness ~0.03: the one approximation.
"""

from __future__ import annotations

import numpy as np

IOR = 1.5
F0 = ((1.0 - IOR) / (1.0 + IOR)) ** 2   # 0.04: the dielectric's Schlick f0 (B.3.4)
MIN_ALPHA = 1e-3                        # = materials.MIN_ALPHA (no import: materials imports this module)


def alpha(roughness: float) -> float:
    """GGX alpha of a perceptual roughness in [0, 1] (alpha = roughness^2), floored at MIN_ALPHA."""
    return max(float(roughness) ** 2, MIN_ALPHA)


def uses(table, ids) -> dict[str, bool]:
    """The features.Uses field: whether some used material is a metal-rough one."""
    return {"metalrough": any(table.types[i] == "metalrough" for i in table.used(ids))}


def pack(table, out: np.ndarray) -> None:
    """Texel 3 of each metal-rough row: metallic, the metallic-roughness texture id (as a float, -1:
    none) and the perceptual roughness factor sqrt(alpha) (the texture's green scales it per texel)."""
    for i, t in enumerate(table.types):
        if t == "metalrough":
            row = [table.metallic[i], float(table.metal_rough[i]), np.sqrt(table.alpha[i])]
            out[i, 3, :3] = np.float32(row).view(np.uint32)
            out[i, 3, 3] = 0

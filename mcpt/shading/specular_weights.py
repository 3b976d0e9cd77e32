"""Specular weights (issue #22): Mitsuba 3's ``specular_reflectance`` and ``specular_transmittance``
factors on glass (``dielectric``, ``roughdielectric``, ``thindielectric``) and ``specular_reflectance``
on the plastics' coat (``plastic``, ``roughplastic``). GLSL side: glsl/materials.glsl (SPEC_R /
SPEC_T) and glsl/specular_weights.glsl (the texture lookup).

As Mitsuba applies them (src/bsdfs/dielectric.cpp, roughdielectric.cpp, thindielectric.cpp,
plastic.cpp, roughplastic.cpp): the factor multiplies the reflected (transmitted) lobe's value and
sample weight; which lobe is sampled stays the Fresnel choice (the pdf does not change). A glass
interior's Beer-Lambert absorption and media are applied to the path as before, separately.

Table: with some used material carrying a factor other than 1 (``Uses.specular_weights``), every
material gets 2 more texels at ``spec_texel`` (after texel 4 when a complex-Fresnel conductor is
there, before a rough plastic's 16-texel table): (specular_reflectance.rgb, texture id) and
(specular_transmittance.rgb, texture id), texture id 0xffffffff none; a texture replaces its
constant (sRGB-decoded 8-bit image, as Mitsuba's bitmap with raw=false). Without such a material
nothing is compiled and the pixels are those of the program without the feature.
"""

from __future__ import annotations

import numpy as np

#: The material types that take a factor, and which: reflection (R) and / or transmission (T).
WEIGHTED = {"dielectric": "RT", "roughdielectric": "RT", "thindielectric": "RT", "plastic": "R",
            "roughplastic": "R"}
ONE = (1.0, 1.0, 1.0)
NO_TEXTURE = 0xFFFFFFFF


def is_one(value) -> bool:
    """A factor that changes nothing: absent, or the constant 1 (Mitsuba's default)."""
    return value is None or (isinstance(value, tuple) and all(c == 1.0 for c in value))


def column(ym) -> tuple | None:
    """The table row's (reflectance, transmittance) of YAML material ``ym``, each an RGB tuple or a
    texture reference; None where both are 1 (the row is today's)."""
    if ym is None or ym.type not in WEIGHTED:
        return None
    r = ym.specular_reflectance
    t = getattr(ym, "specular_transmittance", None)
    r = tuple(r) if isinstance(r, (list, tuple)) else r
    t = tuple(t) if isinstance(t, (list, tuple)) else t
    if is_one(r) and is_one(t):
        return None
    return (ONE if r is None else r, ONE if t is None else t)


def textured(table, i: int) -> bool:
    """Whether row ``i``'s factors read a texture (UVs and the texture buffer are needed)."""
    w = table.spec_weights[i]
    return w is not None and (w[0][1] >= 0 or w[1][1] >= 0)


def uses(table, ids) -> dict[str, bool]:
    """The features.Uses field: some used material has a factor other than 1."""
    return {"specular_weights": any(table.spec_weights[i] is not None for i in table.used(ids))}


def coat_weight(albedo_mean: float, spec_mean: float) -> float:
    """A rough plastic's coat sampling weight as Mitsuba's: s_mean / (d_mean + s_mean)."""
    return spec_mean / (albedo_mean + spec_mean)


def pack(table, out: np.ndarray, spec_texel: int) -> None:
    """Write each row's two factor texels at ``spec_texel`` (out: (M, texels, 4) uint32)."""
    if not spec_texel:
        return
    for i, w in enumerate(table.spec_weights):
        for j, (rgb, tex) in enumerate(w if w is not None else ((ONE, -1), (ONE, -1))):
            out[i, spec_texel + j, :3] = np.asarray(rgb, np.float32).view(np.uint32)
            out[i, spec_texel + j, 3] = NO_TEXTURE if tex < 0 else tex


"""Material table (GLSL side: glsl/materials.glsl).

``features.material_texels`` RGBA32UI texels per material (floats travel as bits):

    0: albedo.rgb, type id          albedo: the colour a texture replaces: diffuse / plastic
                                    reflectance; conductor: Schlick's F0, or the lobe scale
                                    (specular_reflectance) with fresnel none / conductor
    1: emission.rgb, light_pdf_area density with which NEE picks a point of this material
                                    per unit area (needed for MIS, mcpt/shading/lights.py);
                                    with emission textures the emission texture id instead
                                    (the density is per triangle: emission_texture.py)
    2: alpha, ior, texture, flags   GGX alpha (conductor), index of refraction (dielectric,
                                    plastic), albedo texture id (0xffffffff: none), flags:
                                    bit 0 smooth normals, bits 1-2 conductor Fresnel mode
                                    (0 Schlick, 1 none, 2 complex), bit 3 one-sided, bits 4-5
                                    Beckmann, separable masking (mcpt/shading/microfacet.py),
                                    bit 6 nonlinear, bits 16-31 the roughness texture id + 1
                                    (0: none; mcpt/shading/roughness_texture.py)
    3: sigma_a.rgb, fdr_int         absorption coefficient per unit length (dielectric);
                                    conductor: Schlick's lobe scale (specular_reflectance), or
                                    eta (complex Fresnel); the coat's internal diffuse
                                    Fresnel reflectance (plastic)
    4: k.rgb, 0                     conductor with complex Fresnel: the extinction coefficient;
                                    metal-rough: the dielectric's F0.rgb, F90 (KHR_materials_ior /
                                    _specular; with MCPT_METALROUGH_SPECULAR)
                                    metal-rough (mcpt/shading/metalrough.py): 3.x metallic,
                                    3.y its metallic-roughness texture id (a float, -1: none),
                                    3.z the perceptual roughness factor
    spec_texel, +1                  issue #22's specular weights (specular_weights.py): 2 texels
                                    (reflectance.rgb, texture id), (transmittance.rgb, texture id)
                                    after texel 4 (if any), only when some material has one
    last 16                         rough plastic (mcpt/shading/roughplastic.py): 3.x the coat's
                                    sampling weight, 3.w Fdr_int, then T at 64 cosines

Texels 2 and 3 exist only when the scene needs one of their values (the data diet): a
diffuse-only scene without textures, smooth normals or one-sided materials uploads 2 texels per
material; texel 4 only when some conductor uses the complex Fresnel.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from . import metalrough, microfacet, roughness_texture, specular_weights

TYPES = {"diffuse": 0, "conductor": 1, "dielectric": 2, "plastic": 3, "roughdielectric": 4, "thindielectric": 5,
         "roughplastic": 6, "metalrough": 7}
#: Glass has two sides by nature: never one-sided.
TWO_SIDED_TYPES = ("dielectric", "roughdielectric", "thindielectric")

FLAG_SMOOTH_NORMALS = 1
FRESNEL = {"schlick": 0, "none": 1, "conductor": 2}
FRESNEL_SHIFT = 1             # flags bits 1-2: the conductor's Fresnel mode
FLAG_ONE_SIDED = 8            # the back side is black
FLAG_NONLINEAR = 64           # plastics: Mitsuba's nonlinear (bits 4-5: microfacet.py)
NO_TEXTURE = 0xFFFFFFFF

#: GGX alpha below which a conductor is a perfect mirror (pbrt-v4's EffectivelySmooth): the
#: microfacet density of smaller alphas is too peaked for float32.
MIN_ALPHA = 1e-3


def fresnel_dielectric(cos_i, eta):
    """Unpolarised Fresnel reflectance for light arriving at cos_i (> 0) on the side where the
    relative index of the other side is ``eta`` (= n_t / n_i); 1 under total internal reflection.
    The same formula as glsl/bsdf_dielectric.glsl, in float64."""
    cos_i = np.asarray(cos_i, np.float64)
    sin2_t = (1.0 - cos_i**2) / eta**2
    tir = sin2_t >= 1.0
    cos_t = np.sqrt(np.maximum(1.0 - sin2_t, 0.0))
    rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return np.where(tir, 1.0, 0.5 * (rs**2 + rp**2))


@lru_cache(maxsize=256)
def fresnel_diffuse_reflectance(eta: float) -> float:
    """Hemispherical average of the Fresnel reflectance, 2 * int_0^1 F(mu) mu dmu, for uniformly
    diffuse light arriving from the side where the other side has relative index ``eta``.
    Gauss-Legendre on a smooth integrand (eta >= 1: no total internal reflection)."""
    if eta < 1.0:
        raise ValueError("use fdr_internal for eta < 1")
    x, w = np.polynomial.legendre.leggauss(256)
    mu = 0.5 * (x + 1.0)
    return float(np.sum(0.5 * w * fresnel_dielectric(mu, eta) * 2.0 * mu))


def fdr_internal(ior: float) -> float:
    """Diffuse Fresnel reflectance seen from INSIDE a coat of index ``ior`` (with total internal
    reflection), from the external one by the reciprocity relation 1 - Fdr_int = (1 - Fdr_ext) / ior^2.
    This exact identity is what makes a white plastic reflect all light it receives."""
    return 1.0 - (1.0 - fresnel_diffuse_reflectance(float(ior))) / float(ior) ** 2


def plastic_spec_prob(albedo, cos_o, ior: float):
    """The probability that the smooth plastic (glsl/bsdf_plastic.glsl, same formula) samples its
    coat: Mitsuba 3's rule (src/bsdfs/plastic.cpp), Fo w / (Fo w + (1 - Fo)(1 - w)) with Fo the
    coat's Fresnel reflectance at cos_o and w = 1 / (1 + mean(albedo)) (the albedo at the hit, where
    Mitsuba takes a texture's mean). Issue #21 "Variance": it replaced Fo / (Fo + (1 - Fo) max3(A)),
    whose rarer coat samples carry larger weights Fo / ps (README, "Smooth plastic's lobe choice")."""
    fo = fresnel_dielectric(cos_o, ior)
    w = 1.0 / (1.0 + np.mean(np.asarray(albedo, np.float64), axis=-1))
    return fo * w / (fo * w + (1.0 - fo) * (1.0 - w))


@dataclass(frozen=True)
class MaterialTable:
    names: tuple[str, ...]
    types: tuple[str, ...]
    albedo: np.ndarray          # (M, 3) linear RGB reflectance
    emission: np.ndarray        # (M, 3) emitted radiance, front side only
    alpha: np.ndarray = None    # (M,) microfacet alpha (conductor, 0: mirror; rough dielectric)
    ior: np.ndarray = None      # (M,) index of refraction (dielectric, plastic)
    texture: np.ndarray = None  # (M,) albedo texture id, -1: none
    smooth: np.ndarray = None   # (M,) bool: shade with vertex normals
    sigma_a: np.ndarray = None  # (M, 3) absorption per unit length (dielectric)
    fresnel: tuple = None       # (M,) conductor Fresnel mode: "schlick", "none", "conductor"
    spec: np.ndarray = None     # (M, 3) conductor lobe scale under Schlick (specular_reflectance)
    eta: np.ndarray = None      # (M, 3) conductor complex index, real part (fresnel: conductor)
    k: np.ndarray = None        # (M, 3) conductor complex index, imaginary part
    one_sided: np.ndarray = None  # (M,) bool: the back side is black
    normal_map: tuple = None    # (M,) (texture id, scale, right_handed, bump) or None (mcpt/shading/normal_map.py)
    opacity: tuple = None       # (M,) (texture id, cutoff or None) or None (mcpt/shading/opacity.py)
    distribution: tuple = None  # (M,) rough materials: "ggx" or "beckmann" (microfacet.py)
    masking: tuple = None       # (M,) rough materials: "height_correlated" or "separable"
    nonlinear: np.ndarray = None  # (M,) bool: a plastic's nonlinear mode
    coat: np.ndarray = None     # (M, 65) rough plastic: T at 64 cosines, Fdr_int (roughplastic.py)
    metallic: np.ndarray = None  # (M,) metal-rough: glTF metallic in [0, 1] (metalrough.py)
    metal_rough: np.ndarray = None  # (M,) metal-rough: metallic-roughness texture id, -1: none
    emission_texture: np.ndarray = None  # (M,) emission texture id, -1: none (emission_texture.py)
    specular: np.ndarray = None  # (M,) metal-rough: KHR_materials_specular's specularFactor (metalrough.py)
    specular_color: np.ndarray = None  # (M, 3) metal-rough: its specularColorFactor
    # (M,) None or ((reflectance rgb, texture id), (transmittance rgb, texture id)): issue #22's
    # specular weights (mcpt/shading/specular_weights.py)
    spec_weights: tuple = None
    roughness_texture: np.ndarray = None  # (M,) roughness texture id, -1: none (roughness_texture.py)

    def __post_init__(self):
        m = len(self.names)
        defaults = {"alpha": np.zeros(m), "ior": np.full(m, 1.5), "texture": np.full(m, -1, np.int64),
                    "smooth": np.zeros(m, bool), "sigma_a": np.zeros((m, 3)),
                    "fresnel": ("schlick",) * m, "spec": np.ones((m, 3)), "eta": np.ones((m, 3)),
                    "k": np.zeros((m, 3)), "one_sided": np.zeros(m, bool), "normal_map": (None,) * m,
                    "opacity": (None,) * m, "distribution": ("ggx",) * m, "masking": ("height_correlated",) * m,
                    "nonlinear": np.zeros(m, bool), "coat": np.zeros((m, 65)),
                    "metallic": np.zeros(m), "metal_rough": np.full(m, -1, np.int64),
                    "emission_texture": np.full(m, -1, np.int64), "specular": np.ones(m),
                    "specular_color": np.ones((m, 3)), "spec_weights": (None,) * m,
                    "roughness_texture": np.full(m, -1, np.int64)}
        for k, v in defaults.items():
            if getattr(self, k) is None:
                object.__setattr__(self, k, v)

    def used(self, ids) -> list[int]:
        ids = np.asarray(ids).ravel()
        if ids.size and ids.dtype.kind in "iu" and 0 <= ids.min() and ids.max() < len(self.names):
            # Counting is one pass over 10^6 triangles; np.unique hashes them (10x slower, issue #23).
            return np.flatnonzero(np.bincount(ids)).tolist()
        return sorted({int(i) for i in np.unique(ids)})

    def is_rough(self, i: int) -> bool:
        """Whether material ``i`` is a microfacet surface (alpha >= MIN_ALPHA: a rough conductor;
        a rough dielectric always is)."""
        return (self.types[i] in ("conductor", "roughdielectric", "roughplastic", "metalrough")
                and self.alpha[i] >= MIN_ALPHA)

    def rough(self, ids) -> bool:
        return any(self.is_rough(i) for i in self.used(ids))

    def absorbing(self, ids) -> bool:
        return any(self.types[i] == "dielectric" and self.sigma_a[i].max() > 0 for i in self.used(ids))

    def textured(self, ids) -> bool:
        return any(self.texture[i] >= 0 or self.normal_map[i] is not None or self.opacity[i] is not None
                   or self.metal_rough[i] >= 0 or self.emission_texture[i] >= 0 or self.roughness_texture[i] >= 0
                   or specular_weights.textured(self, i) for i in self.used(ids))

    def cut_out(self, ids) -> bool:
        return any(self.opacity[i] is not None for i in self.used(ids))

    def normal_mapped(self, ids) -> bool:
        return any(self.normal_map[i] is not None for i in self.used(ids))

    def smooth_shaded(self, ids) -> bool:
        return any(bool(self.smooth[i]) for i in self.used(ids))

    def complex_fresnel(self, ids) -> bool:
        return any(self.types[i] == "conductor" and self.fresnel[i] == "conductor" for i in self.used(ids))

    def one_sided_used(self, ids) -> bool:
        return any(bool(self.one_sided[i]) and self.types[i] not in TWO_SIDED_TYPES for i in self.used(ids))

    def pack(self, light_pdf_area: np.ndarray, texels: int = 2, emission_textures: bool = False,
             spec_texel: int = 0, fifth: bool = False) -> np.ndarray:
        """The table (texels per material, the layout above); ``fifth``: texel 4 exists (a
        complex-Fresnel conductor's k, or a metal-rough row's F0, F90); ``spec_texel``: the first of
        the 2 specular-weight texels, 0 for none (all three from features.Uses)."""
        m = len(self.names)
        out = np.zeros((max(m, 1), texels, 4), np.uint32)
        f32 = lambda a: np.asarray(a, np.float32).view(np.uint32)  # noqa: E731
        out[:m, 0, :3] = f32(self.albedo)
        out[:m, 0, 3] = [TYPES[t] for t in self.types]
        out[:m, 1, :3] = f32(self.emission)
        out[:m, 1, 3] = f32(light_pdf_area)
        if emission_textures:  # 1.w: the emission texture; the density is per triangle (emit_pdf)
            out[:m, 1, 3] = np.where(self.emission_texture >= 0, self.emission_texture, NO_TEXTURE).astype(np.uint32)
        if texels >= 4:
            alpha = np.where(self.alpha >= MIN_ALPHA, self.alpha, 0.0)
            out[:m, 2, 0] = f32(alpha)
            out[:m, 2, 1] = f32(self.ior)
            out[:m, 2, 2] = np.where(self.texture >= 0, self.texture, NO_TEXTURE).astype(np.uint32)
            conductor = np.array([t == "conductor" for t in self.types], bool)
            mode = np.array([FRESNEL[f] if c else 0 for f, c in zip(self.fresnel, conductor)], np.uint32)
            one = self.one_sided & np.array([t not in TWO_SIDED_TYPES for t in self.types], bool)
            mf = [microfacet.flags(d, g) for d, g in zip(self.distribution, self.masking)]
            out[:m, 2, 3] = (np.where(self.smooth, FLAG_SMOOTH_NORMALS, 0) | (mode << FRESNEL_SHIFT)
                             | np.where(one, FLAG_ONE_SIDED, 0) | np.asarray(mf, np.int64)
                             | np.where(self.nonlinear, FLAG_NONLINEAR, 0)
                             | roughness_texture.flag_bits(self)).astype(np.uint32)
            # Texel 3 rgb per type: sigma_a (dielectric), Schlick's lobe scale or eta (conductor).
            third = np.where(conductor[:, None], np.where((mode == FRESNEL["conductor"])[:, None],
                                                          self.eta, self.spec), self.sigma_a)
            out[:m, 3, :3] = f32(third)
            fdr = [fdr_internal(self.ior[i]) if t == "plastic" else 0.0 for i, t in enumerate(self.types)]
            out[:m, 3, 3] = f32(fdr)
            self._pack_rough_plastic(out, texels)
        if fifth:
            out[:m, 4, :3] = f32(self.k)
        if texels >= 4:  # after k: a metal-rough row's texel 4 holds its F0, F90 (metalrough.py)
            metalrough.pack(self, out, fifth)
        specular_weights.pack(self, out, spec_texel)  # issue #22: 2 texels at spec_texel
        return out.reshape(-1, 4)

    def _pack_rough_plastic(self, out: np.ndarray, texels: int) -> None:
        """Rough plastic (mcpt/shading/roughplastic.py): the coat's sampling weight 1 / (1 + mean A)
        in texel 3.x, Fdr_int in 3.w, the 64-entry transmittance table in the last 16 texels."""
        for i, t in enumerate(self.types):
            if t != "roughplastic":
                continue
            w = 1.0 / (1.0 + float(np.mean(self.albedo[i])))
            if self.spec_weights[i] is not None:  # Mitsuba's s_mean / (d_mean + s_mean) (issue #22)
                spec_mean = float(np.mean(self.spec_weights[i][0][0]))
                w = specular_weights.coat_weight(float(np.mean(self.albedo[i])), spec_mean)
            out[i, 3, :3] = np.float32([w, 0.0, 0.0]).view(np.uint32)
            out[i, 3, 3] = np.float32(self.coat[i, 64]).view(np.uint32)
            out[i, texels - 16:texels] = np.asarray(self.coat[i, :64], np.float32).view(np.uint32).reshape(16, 4)

"""Material descriptions as the scene file states them (the GPU table: mcpt/shading/materials.py)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import (
    BeforeValidator,
    Field,
    ValidationInfo,
    field_validator,
    model_validator,
)

from ..shading.metals import METALS
from ..shading.roughdielectric import MIN_ALPHA as ROUGH_GLASS_MIN_ALPHA
from .diagnostics import FieldError
from .fields import Albedo, Radiance, StrictModel, fixed_list
from .medium import Medium
from .textures import (
    BumpMap,
    CheckerboardTexture,
    ImageTexture,
    NormalMap,
    RoughnessTexture,
    colour_or_texture,
    normal_map_shorthand,
    texture,
    texture_shorthand,
)

_Positive = Annotated[float, Field(gt=0.0, le=100.0)]
_NonNegative = Annotated[float, Field(ge=0.0, le=100.0)]
#: The real part of a complex index of refraction, per RGB channel (dimensionless, > 0).
Eta = Annotated[tuple[_Positive, _Positive, _Positive], fixed_list(3)]
#: The extinction coefficient (imaginary part), per RGB channel (dimensionless, >= 0).
Extinction = Annotated[tuple[_NonNegative, _NonNegative, _NonNegative], fixed_list(3)]


class Absorption(StrictModel):
    """Beer-Lambert absorption inside a dielectric: light that travels ``distance`` through the
    medium keeps the fraction ``color`` of itself (sigma_a = -ln(color) / distance)."""

    color: Annotated[
        tuple[
            Annotated[float, Field(gt=0.0, le=1.0)],
            Annotated[float, Field(gt=0.0, le=1.0)],
            Annotated[float, Field(gt=0.0, le=1.0)],
        ],
        fixed_list(3),
    ]
    """Transmittance after ``distance``, linear RGB, each in (0, 1]."""
    distance: Annotated[float, Field(gt=0.0)]
    """The distance (world units) at which the transmittance is ``color``."""


#: Which optional keys each material type accepts (``emission`` and ``smooth_normals``: all).
MATERIAL_KEYS = {
    "diffuse": ("albedo", "albedo_texture", "two_sided"),
    "conductor": ("albedo", "albedo_texture", "roughness", "fresnel", "eta", "k", "metal",
                  "specular_reflectance", "two_sided", "distribution", "masking", "roughness_texture"),
    "dielectric": ("ior", "absorption", "interior", "specular_reflectance", "specular_transmittance"),
    "plastic": ("albedo", "albedo_texture", "ior", "nonlinear", "two_sided", "specular_reflectance"),
    "roughdielectric": ("ior", "roughness", "distribution", "masking", "specular_reflectance",
                        "specular_transmittance", "roughness_texture"),
    "thindielectric": ("ior", "specular_reflectance", "specular_transmittance"),
    "roughplastic": ("albedo", "albedo_texture", "ior", "roughness", "distribution", "masking", "nonlinear",
                     "two_sided", "specular_reflectance"),
    "metalrough": ("albedo", "albedo_texture", "metallic", "roughness", "masking", "two_sided",
                   "metallic_roughness_texture", "ior", "specular", "specular_color"),
}
_OPTIONAL = ("albedo", "albedo_texture", "roughness", "ior", "absorption", "fresnel", "eta", "k",
             "metal", "specular_reflectance", "two_sided", "distribution", "masking", "nonlinear", "interior",
             "metallic", "metallic_roughness_texture", "specular", "specular_color", "specular_transmittance",
             "roughness_texture")
_Unbounded = Annotated[float, Field(ge=0.0, allow_inf_nan=False)]


class Material(StrictModel):
    """A surface material (GLSL: glsl/bsdf_<type>.glsl; table: mcpt/shading/materials.py).

    * ``diffuse``: Lambertian, reflectance ``albedo`` (or ``albedo_texture``).
    * ``conductor``: metal. ``roughness`` is the microfacet alpha: 0 (below 0.001) is a perfect
      mirror, larger values a rough metal of ``distribution`` ``ggx`` (default, visible-normal
      sampling) or ``beckmann``, with Smith ``masking`` ``height_correlated`` (default) or
      ``separable`` (Mitsuba 3's). The
      Fresnel factor (``fresnel``): ``schlick`` (default) with ``albedo`` the reflectance at normal
      incidence; ``none``, F = 1 at every angle (Mitsuba's ``material: none``, the reference
      mirror); ``conductor``, the exact unpolarised Fresnel of a complex index ``eta`` + i ``k``
      (RGB) or of a measured ``metal`` (mcpt/shading/metals.py). ``specular_reflectance`` (RGB or
      an image) scales the lobe in every mode (default 1).
    * ``dielectric``: smooth glass, exact unpolarised Fresnel, refraction by ``ior`` (outside is
      air, the front side is outside), total internal reflection, optional ``absorption``.
    * ``plastic``: a Lambertian base (``albedo``) under a smooth dielectric coat of index ``ior``:
      a mirror-like reflection (Fresnel) plus diffuse light that got through the coat, including
      the light the coat reflects back onto the base. A white plastic reflects all light.
      ``nonlinear`` (default true here) as Mitsuba's: false divides the base by 1 - Fdr_int, true
      by 1 - A Fdr_int (Mitsuba's plastic defaults to false: its reader says so explicitly).
    * ``roughdielectric``: frosted glass, a rough interface of index ``ior`` (Walter et al. 2007,
      Mitsuba 3's ``roughdielectric``): ``roughness`` (alpha in [0.001, 1]), ``distribution``,
      ``masking`` as for a rough conductor (glsl/bsdf_roughdielectric.glsl).
    * ``thindielectric``: a window pane of index ``ior`` (Mitsuba 3's ``thindielectric``): light
      passes unrefracted or reflects, the pane's internal reflections summed.
    * ``roughplastic``: Mitsuba 3's ``roughplastic``: a Lambertian base (``albedo``) under a rough
      dielectric coat (``ior``, ``roughness`` in [0.001, 1], ``distribution``, ``masking``), the
      coat's internal reflections by Mitsuba's ``nonlinear`` rule (default false).
    * ``metalrough``: glTF 2.0's metal-rough material as the glTF specification's appendix B defines
      it (mcpt/shading/metalrough.py): base colour ``albedo`` (or ``albedo_texture``), ``metallic``
      in [0, 1] and the perceptual ``roughness`` in [0, 1] (GGX alpha = roughness^2), both 1 when
      absent as in glTF; ``masking`` as for a rough conductor. With both ``albedo`` and
      ``albedo_texture`` the base colour is their product (glTF's baseColorFactor x texture);
      ``metallic_roughness_texture`` scales ``metallic`` by its blue and ``roughness`` by its green
      channel per texel (glTF's metallicRoughnessTexture, linear). ``ior`` (KHR_materials_ior: >= 1,
      or 0; default 1.5), ``specular`` (KHR_materials_specular's specularFactor in [0, 1], default 1)
      and ``specular_color`` (its specularColorFactor, >= 0, default [1, 1, 1]) set the dielectric's
      Fresnel as those extensions define it (issue #21 item 5); the metal is unaffected.

    Every type may emit (``emission``, front side only) and may use smooth shading normals
    interpolated from vertex normals (``smooth_normals``). Diffuse, conductor and plastic take
    ``two_sided`` (default true: both sides reflect alike, what Mitsuba 3's ``twosided`` wrapper
    does); ``two_sided: false`` makes the back side black, as Mitsuba 3's bare BSDFs are. Glass has
    two sides by nature.
    """

    type: Literal["diffuse", "conductor", "dielectric", "plastic", "roughdielectric", "thindielectric",
                  "roughplastic", "metalrough"] = "diffuse"
    """Material model: diffuse, conductor, dielectric, plastic, roughdielectric, thindielectric,
    roughplastic or metalrough."""
    albedo: Albedo | None = None
    """Linear RGB reflectance in [0, 1]; None = the mesh's MTL ``Kd``, else 0.8 grey. For a
    conductor: the reflectance at normal incidence."""
    albedo_texture: ImageTexture | CheckerboardTexture | None = None
    """An image as the albedo (a file name or ``{file, wrap, filter, uv}``) or a checkerboard
    (``{type: checkerboard, color0, color1, uv}``, mcpt/scene/textures.py); excludes ``albedo``."""
    roughness: Annotated[float, Field(ge=0.0, le=1.0)] = 0.0
    """Conductor: the microfacet alpha in [0, 1], 0 = mirror; roughdielectric: [0.001, 1]; metalrough:
    glTF's perceptual roughness (alpha = roughness^2)."""
    metallic: Annotated[float, Field(ge=0.0, le=1.0)] | None = None
    """Metalrough: glTF's metallic in [0, 1] (None: 1, glTF's default)."""
    metallic_roughness_texture: ImageTexture | None = None
    """Metalrough: glTF's metallicRoughnessTexture, read linearly: its blue channel times ``metallic``,
    its green times ``roughness``, per texel."""
    specular: Annotated[float, Field(ge=0.0, le=1.0)] = 1.0
    """Metalrough: KHR_materials_specular's specularFactor (the dielectric's F0 and F90 scale)."""
    specular_color: Annotated[tuple[_Unbounded, _Unbounded, _Unbounded], fixed_list(3)] = (1.0, 1.0, 1.0)
    """Metalrough: KHR_materials_specular's specularColorFactor (linear RGB, >= 0; F0 = min(f0(ior)
    x this, 1) x specular)."""
    roughness_texture: RoughnessTexture | None = None
    """Conductor, roughdielectric (issue #22): a texture whose first channel times ``roughness`` (1 when
    absent) is alpha per hit (a file name or ``{file, uv, wrap, filter, encoding}``, read linearly)."""
    distribution: Literal["ggx", "beckmann"] = "ggx"
    """Rough conductor or dielectric: the microfacet distribution (mcpt/shading/microfacet.py)."""
    masking: Literal["height_correlated", "separable"] = "height_correlated"
    """Rough conductor or dielectric: the Smith masking-shadowing term, height-correlated (Heitz 2014) or
    separable G1(wo) G1(wi) (Mitsuba 3's; the Mitsuba reader picks it)."""
    ior: Annotated[float, Field(allow_inf_nan=False)] = 1.5
    """Dielectric, plastic: index of refraction in (1, 4] (the outside is air, index 1: the relative
    index, the denser medium inside)."""
    absorption: Absorption | None = None
    """Dielectric: Beer-Lambert absorption of light travelling inside (None: clear)."""
    interior: Medium | None = None
    """Dielectric: a participating medium filling its (closed) meshes (issue #25, mcpt/scene/medium.py)."""
    fresnel: Literal["schlick", "none", "conductor"] | None = None
    """Conductor: the Fresnel factor, ``schlick`` (F0 = albedo), ``none`` (F = 1) or ``conductor``
    (complex index ``eta``, ``k`` or ``metal``). Default: ``conductor`` when ``eta``/``k``/``metal``
    is given, else ``schlick``."""
    eta: Eta | None = None
    """Conductor with ``fresnel: conductor``: real part of the complex index (RGB), relative to air."""
    k: Extinction | None = None
    """Conductor with ``fresnel: conductor``: extinction coefficient (RGB), with ``eta``."""
    metal: Literal[tuple(METALS)] | None = None  # type: ignore[valid-type]
    """Conductor: a measured metal (Au, Ag, Cu, Al, Cr) instead of ``eta`` and ``k``."""
    specular_reflectance: Albedo | ImageTexture | CheckerboardTexture | None = None
    """Conductor: linear RGB factor on the lobe, in [0, 1] (a number: grey), or an image
    (``fresnel: none`` or ``conductor`` only); None = 1. Dielectric, roughdielectric, thindielectric,
    plastic, roughplastic: Mitsuba 3's factor on the reflected lobe (the coat's), RGB or an image
    (issue #22, mcpt/shading/specular_weights.py)."""
    specular_transmittance: Albedo | ImageTexture | CheckerboardTexture | None = None
    """Dielectric, roughdielectric, thindielectric: Mitsuba 3's factor on the transmitted lobe, RGB
    in [0, 1] or an image; None = 1 (issue #22). An interior's absorption applies besides."""
    two_sided: bool = True
    """Diffuse, conductor, plastic: whether the back side reflects like the front (false: black)."""
    emission: Radiance | None = None
    """Emitted radiance (W sr^-1 m^-2, linear RGB, >= 0), front side only; None = MTL ``Ke``, else 0."""
    emission_texture: ImageTexture | CheckerboardTexture | None = None
    """Emitted radiance as an image (issue #22, mcpt/shading/emission_texture.py): radiance at a
    point = the texture there (sRGB-decoded) x ``emission`` (a scale; default 1); light sampling
    picks each triangle by its textured power."""
    normal_map: Annotated[NormalMap | None, BeforeValidator(normal_map_shorthand)] = None
    """A tangent-space normal map (a file name or ``{file, scale, handedness, wrap, filter, uv}``,
    mcpt/scene/textures.py); any type."""
    opacity: ImageTexture | CheckerboardTexture | None = None
    """Opacity cut-out (mcpt/shading/opacity.py): a texture whose luminance is the opacity
    (a file name, ``{file, ...}`` or a checkerboard); rays pass where it is transparent. Not on
    an emitter."""
    opacity_cutoff: Annotated[float, Field(ge=0.0, le=1.0)] | None = None
    """With ``opacity``: absent where opacity < cutoff (glTF MASK); None: absent with probability
    1 - opacity (glTF BLEND, Mitsuba's mask)."""
    bump_map: Annotated[BumpMap | None, BeforeValidator(normal_map_shorthand)] = None
    """A height image (a file name or ``{file, scale, encoding, wrap}``, mcpt/scene/textures.py);
    any type; excludes ``normal_map``."""
    nonlinear: bool | None = None
    """Plastic, rough plastic: Mitsuba's ``nonlinear`` (the base's albedo inside the internal-reflection
    sum); None: true for ``plastic`` (mcpt's model since issue #3), false for ``roughplastic`` (Mitsuba's
    default)."""
    smooth_normals: bool = False
    """Shade with normals interpolated from the mesh's vertex normals (Assimp generates smooth
    ones when the file has none); the flat triangle normal still decides offsets and leaks."""

    @field_validator("specular_reflectance", "specular_transmittance", mode="before")
    @classmethod
    def _reflectance(cls, value: Any, info: ValidationInfo) -> Any:
        return None if value is None else colour_or_texture(value, info)

    @field_validator("albedo_texture", "opacity", "metallic_roughness_texture", "emission_texture", mode="before")
    @classmethod
    def _albedo_texture(cls, value: Any, info: ValidationInfo) -> Any:
        return texture(value, info)

    @field_validator("roughness_texture", mode="before")
    @classmethod
    def _roughness_texture(cls, value: Any) -> Any:
        return texture_shorthand(value)

    @model_validator(mode="after")
    def _check_keys(self) -> Material:
        allowed = MATERIAL_KEYS[self.type]
        if self.type == "roughplastic" and self.roughness_texture is not None:  # issue #22
            raise FieldError(("roughness_texture",), "a roughplastic takes no roughness_texture: its coat's "
                                                     "transmittance tables are computed for one alpha (Mitsuba 3's "
                                                     "roughplastic alpha is a number too); use a roughness")
        for key in _OPTIONAL:
            if key in self.model_fields_set and key not in allowed:
                users = [t for t, keys in MATERIAL_KEYS.items() if key in keys]
                raise FieldError(
                    (key,), f"a {self.type} material has no {key} (it is a parameter of: {', '.join(users)})"
                )
        if self.albedo is not None and self.albedo_texture is not None and self.type != "metalrough":
            raise FieldError(("albedo_texture",), "give albedo or albedo_texture, not both")
        if self.absorption is not None and self.interior is not None:  # issue #25
            raise FieldError(("interior",), "give absorption or interior (its sigma_a absorbs), not both")
        if self.opacity is not None and (self.emission_texture is not None
                                         or (self.emission is not None and max(self.emission) > 0)):
            raise FieldError(("opacity",), "an emitter cannot be cut out (light sampling needs its area)")
        if self.opacity_cutoff is not None and self.opacity is None:
            raise FieldError(("opacity_cutoff",), "opacity_cutoff needs an opacity texture")
        if self.normal_map is not None and self.bump_map is not None:
            raise FieldError(("bump_map",), "give normal_map or bump_map, not both")
        if self.type == "conductor":
            self._check_fresnel()
        # ior 1 is no interface; a smooth dielectric holding an interior medium may have it: the
        # medium's index-matched boundary (Mitsuba's null BSDF around a medium, issue #25).
        matched = self.type == "dielectric" and self.interior is not None
        if self.type in ("dielectric", "roughdielectric", "thindielectric", "plastic", "roughplastic") \
                and self.ior == 1.0 and not matched:  # plastic too: issue #21 item 3 (it rendered as a bare base)
            raise FieldError(("ior",), "ior 1 is no interface (the same index on both sides: the "
                                       "surface would be invisible); a dielectric needs ior > 1 "
                                       "(or an interior medium, whose boundary it then is)")
        self._check_ior()
        if self.roughness_texture is not None and self.alpha < ROUGH_GLASS_MIN_ALPHA:  # issue #22
            raise FieldError(("roughness",), f"roughness {self.roughness:g} with a roughness_texture: the texture "
                                             f"scales roughness, so every texel would be smooth (give roughness "
                                             f"in [{ROUGH_GLASS_MIN_ALPHA:g}, 1], or none: 1)")
        if self.type in ("roughdielectric", "roughplastic") and self.alpha < ROUGH_GLASS_MIN_ALPHA:
            raise FieldError(("roughness",), f"a {self.type} needs roughness (alpha) in "
                                             f"[{ROUGH_GLASS_MIN_ALPHA:g}, 1], got {self.roughness:g} "
                                             f"(smooth glass is type: dielectric)")
        return self

    def _check_ior(self) -> None:
        """An interface's index in mcpt's range [1, 4], what one below 1 means said in words (issue
        #21 item 3: pydantic's "greater than or equal to 1" did not)."""
        x = self.ior
        if self.type == "metalrough":  # a Fresnel parameter, not an interface: KHR_materials_ior's range
            if x != 0.0 and x < 1.0:
                raise FieldError(("ior",), f"ior {x:g}: KHR_materials_ior allows ior >= 1, or 0 (F0 = 1: the "
                                           f"specular-glossiness conversion); below 1 is not an index mcpt reads")
            return
        if x > 4.0:
            raise FieldError(("ior",), f"ior {x:g} is above 4, mcpt's range for an interface's index")
        if x <= 0.0:
            raise FieldError(("ior",), f"ior {x:g} is no index of refraction: ior is the relative index "
                                       f"inside / outside (the outside is air), > 1 (the denser medium inside)")
        if x < 1.0:
            raise FieldError(("ior",), f"ior {x:g} < 1 is not supported: ior is the relative index inside / "
                                       f"outside (the outside is air) and the denser medium must be inside; flip "
                                       f"the normals (swap the sides) and give 1 / ior = {1.0 / x:.4g}")

    @property
    def alpha(self) -> float:
        """The roughness the table holds: ``roughness``, or 1 with a roughness_texture and no roughness
        (the texture is then alpha itself; issue #22)."""
        if self.roughness_texture is not None and "roughness" not in self.model_fields_set:
            return 1.0
        return self.roughness

    @property
    def nonlinear_mode(self) -> bool:
        """A plastic's nonlinear mode with the type's default resolved."""
        return self.nonlinear if self.nonlinear is not None else self.type == "plastic"

    @property
    def fresnel_mode(self) -> str:
        """The conductor's Fresnel mode with the default resolved."""
        if self.fresnel is not None:
            return self.fresnel
        return "conductor" if {"eta", "k", "metal"} & self.model_fields_set else "schlick"

    def complex_ior(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """(eta, k) of a ``fresnel: conductor`` material."""
        return METALS[self.metal] if self.metal is not None else (self.eta, self.k)

    def _check_fresnel(self) -> None:
        mode = self.fresnel_mode
        given = self.model_fields_set
        if mode == "conductor":
            if self.metal is not None and (self.eta is not None or self.k is not None):
                raise FieldError(("metal",), "give metal or eta and k, not both")
            if self.metal is None and (self.eta is None or self.k is None):
                missing = "k" if self.eta is not None else "eta"
                raise FieldError((missing,), f"fresnel: conductor needs eta and k (RGB), or a metal "
                                              f"({', '.join(METALS)})")
        else:
            for key in ("eta", "k", "metal"):
                if key in given:
                    raise FieldError((key,), f"{key} is a parameter of fresnel: conductor, not {mode}")
        if mode != "schlick":
            for key in ("albedo", "albedo_texture"):
                if key in given:
                    raise FieldError((key,), f"with fresnel: {mode} the conductor's colour is "
                                              f"specular_reflectance, not {key} (Schlick's F0)")
        elif isinstance(self.specular_reflectance, (ImageTexture, CheckerboardTexture)):
            raise FieldError(("specular_reflectance",), "with fresnel: schlick the texture is "
                                                         "albedo_texture (F0); specular_reflectance is RGB")


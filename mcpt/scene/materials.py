"""Material descriptions as the scene file states them (the GPU table: mcpt/shading/materials.py)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, Field, ValidationInfo, field_validator, model_validator

from .diagnostics import _FieldError
from .fields import Albedo, Radiance, _Model, _fixed_list, _texture_file


class ImageTexture(_Model):
    """An image used as a colour (mcpt/shading/texture.py), addressed by the mesh's UVs.

    8-bit images are sRGB-encoded and decoded to linear RGB; the alpha channel is ignored. UV
    (0, 0) is the image's bottom-left corner (OBJ convention: v points up).
    """

    file: Path
    """Image file (PNG, JPEG, ... read by OpenCV), relative to the scene file's folder."""
    wrap: Literal["repeat", "clamp", "mirror"] = "repeat"
    """What UVs outside [0, 1] read: the tiled image, the edge texels, or the mirrored image."""
    filter: Literal["bilinear", "nearest"] = "bilinear"
    """Bilinear interpolation of the four nearest texels (in linear RGB), or the nearest texel."""

    @field_validator("file", mode="before")
    @classmethod
    def _resolve(cls, value: Any, info: ValidationInfo) -> Any:
        return _texture_file(value, info)


def _texture_shorthand(value: Any) -> Any:
    """``albedo_texture: spot.png`` is short for ``albedo_texture: {file: spot.png}``."""
    return {"file": value} if isinstance(value, (str, Path)) else value


class Absorption(_Model):
    """Beer-Lambert absorption inside a dielectric: light that travels ``distance`` through the
    medium keeps the fraction ``color`` of itself (sigma_a = -ln(color) / distance)."""

    color: Annotated[
        tuple[
            Annotated[float, Field(gt=0.0, le=1.0)],
            Annotated[float, Field(gt=0.0, le=1.0)],
            Annotated[float, Field(gt=0.0, le=1.0)],
        ],
        _fixed_list(3),
    ]
    """Transmittance after ``distance``, linear RGB, each in (0, 1]."""
    distance: Annotated[float, Field(gt=0.0)]
    """The distance (world units) at which the transmittance is ``color``."""


#: Which optional keys each material type accepts (``emission`` and ``smooth_normals``: all).
MATERIAL_KEYS = {
    "diffuse": ("albedo", "albedo_texture"),
    "conductor": ("albedo", "albedo_texture", "roughness"),
    "dielectric": ("ior", "absorption"),
    "plastic": ("albedo", "albedo_texture", "ior"),
}


class Material(_Model):
    """A surface material (GLSL: glsl/bsdf_<type>.glsl; table: mcpt/shading/materials.py).

    * ``diffuse``: Lambertian, reflectance ``albedo`` (or ``albedo_texture``).
    * ``conductor``: metal; ``albedo`` is the reflectance at normal incidence, Schlick's Fresnel
      approximation gives the rest. ``roughness`` is the GGX alpha: 0 (below 0.001) is a perfect
      mirror, larger values a rough metal (Smith height-correlated masking, visible-normal sampling).
    * ``dielectric``: smooth glass, exact unpolarised Fresnel, refraction by ``ior`` (outside is
      air, the front side is outside), total internal reflection, optional ``absorption``.
    * ``plastic``: a Lambertian base (``albedo``) under a smooth dielectric coat of index ``ior``:
      a mirror-like reflection (Fresnel) plus diffuse light that got through the coat, including
      the light the coat reflects back onto the base. A white plastic reflects all light.

    Every type may emit (``emission``, front side only) and may use smooth shading normals
    interpolated from vertex normals (``smooth_normals``).
    """

    type: Literal["diffuse", "conductor", "dielectric", "plastic"] = "diffuse"
    """Material model: diffuse, conductor, dielectric or plastic."""
    albedo: Albedo | None = None
    """Linear RGB reflectance in [0, 1]; None = the mesh's MTL ``Kd``, else 0.8 grey. For a
    conductor: the reflectance at normal incidence."""
    albedo_texture: Annotated[ImageTexture | None, BeforeValidator(_texture_shorthand)] = None
    """An image as the albedo (a file name or ``{file, wrap, filter}``); excludes ``albedo``."""
    roughness: Annotated[float, Field(ge=0.0, le=1.0)] = 0.0
    """Conductor: GGX alpha in [0, 1]; 0 = mirror."""
    ior: Annotated[float, Field(ge=1.0, le=4.0)] = 1.5
    """Dielectric, plastic: index of refraction (the outside is air, index 1)."""
    absorption: Absorption | None = None
    """Dielectric: Beer-Lambert absorption of light travelling inside (None: clear)."""
    emission: Radiance | None = None
    """Emitted radiance (W sr^-1 m^-2, linear RGB, >= 0), front side only; None = MTL ``Ke``, else 0."""
    smooth_normals: bool = False
    """Shade with normals interpolated from the mesh's vertex normals (Assimp generates smooth
    ones when the file has none); the flat triangle normal still decides offsets and leaks."""

    @model_validator(mode="after")
    def _check_keys(self) -> Material:
        allowed = MATERIAL_KEYS[self.type]
        for key in ("albedo", "albedo_texture", "roughness", "ior", "absorption"):
            if key in self.model_fields_set and key not in allowed:
                users = [t for t, keys in MATERIAL_KEYS.items() if key in keys]
                raise _FieldError(
                    (key,), f"a {self.type} material has no {key} (it is a parameter of: {', '.join(users)})"
                )
        if self.albedo is not None and self.albedo_texture is not None:
            raise _FieldError(("albedo_texture",), "give albedo or albedo_texture, not both")
        return self


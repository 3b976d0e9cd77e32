"""Texture descriptions as the scene file states them: image textures (``ImageTexture``, a roughness
map's ``RoughnessTexture``, and the parsers of a texture-or-colour key), the UV transform every
texture may carry (``uv``), the procedural checkerboard (mcpt/shading/checkerboard.py), normal and
bump maps. Materials (mcpt/scene/materials.py) name them.

    albedo_texture: {type: checkerboard, color0: [0.9, 0.9, 0.9], color1: [0.1, 0.1, 0.1],
                     uv: {scale: [8, 8]}}
    albedo_texture: {file: wood.png, uv: {scale: [2, 2], rotation: 30, offset: [0.5, 0]}}

The transform maps the mesh's UVs (v up) to the coordinates the texture is read at:
uv' = offset + R(rotation) diag(scale) uv (scale first, then a counter-clockwise rotation in
degrees, then the offset: the order Mitsuba's ``to_uv`` lists them in), or a 2x3 ``matrix``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, TypeAdapter, ValidationError, ValidationInfo, field_validator, model_validator
from pydantic_core import PydanticCustomError

from .diagnostics import FieldError
from .fields import Albedo, StrictModel, fixed_list, texture_file

_Finite = Annotated[float, Field(ge=-1e6, le=1e6)]
_Pair = Annotated[tuple[_Finite, _Finite], fixed_list(2)]
_Row = Annotated[tuple[_Finite, _Finite, _Finite], fixed_list(3)]


class UvTransform(StrictModel):
    """An affine map of texture coordinates (Mitsuba's ``to_uv``)."""

    scale: _Pair = (1.0, 1.0)
    """Factors on u and v (dimensionless; 2 repeats the texture twice across [0, 1])."""
    rotation: _Finite = 0.0
    """Counter-clockwise rotation about uv (0, 0) in degrees, after the scale."""
    offset: _Pair = (0.0, 0.0)
    """Added last, in texture units (1 = one period)."""
    matrix: Annotated[tuple[_Row, _Row], fixed_list(2, "rows")] | None = None
    """The 2x3 matrix itself (rows (a, b, c), (d, e, f): u' = a u + b v + c); excludes the rest."""

    @model_validator(mode="after")
    def _check(self) -> UvTransform:
        if self.matrix is not None and self.model_fields_set & {"scale", "rotation", "offset"}:
            raise FieldError(("matrix",), "give matrix or scale / rotation / offset, not both")
        if 0.0 in self.scale:
            raise FieldError(("scale",), f"scale {list(self.scale)} flattens the texture")
        return self

    def affine(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        if self.matrix is not None:
            return tuple(tuple(float(x) for x in row) for row in self.matrix)
        c, s = math.cos(math.radians(self.rotation)), math.sin(math.radians(self.rotation))
        (sx, sy), (ox, oy) = self.scale, self.offset
        return ((c * sx, -s * sy, ox), (s * sx, c * sy, oy))


IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))


def affine_of(ref: Any) -> tuple:
    """The 2x3 UV map of a texture reference (identity when it has no ``uv``)."""
    uv = getattr(ref, "uv", None)
    return IDENTITY if uv is None else uv.affine()


class CheckerboardTexture(StrictModel):
    """Mitsuba's procedural ``checkerboard``: ``color0`` on the square [0, 1/2)^2 of the
    (transformed) UVs and every square diagonal to it, ``color1`` on the others."""

    type: Literal["checkerboard"]
    color0: Albedo = (0.4, 0.4, 0.4)
    """Linear RGB reflectance of the squares at even (s, t) half-periods (Mitsuba's default 0.4)."""
    color1: Albedo = (0.2, 0.2, 0.2)
    """Linear RGB reflectance of the other squares (Mitsuba's default 0.2)."""
    uv: UvTransform | None = None
    """The UV transform (scale [8, 8]: 8 x 8 pairs of squares over [0, 1]^2)."""


def is_checkerboard(value: Any) -> bool:
    """Whether a YAML texture value asks for the checkerboard (else it is an image)."""
    return isinstance(value, dict) and value.get("type") == "checkerboard"


def texture_key(ref: Any) -> tuple:
    """What makes two texture references the same texture (each is built and uploaded once)."""
    if isinstance(ref, NormalMap):
        return ("normal", str(ref.file), ref.wrap, ref.filter, affine_of(ref))
    if isinstance(ref, BumpMap):
        return ("bump", str(ref.file), ref.wrap, ref.encoding)
    if isinstance(ref, CheckerboardTexture):
        return ("checkerboard", ref.color0, ref.color1, affine_of(ref))
    return (str(ref.file), ref.wrap, ref.filter, affine_of(ref), getattr(ref, "channel", "rgb"), is_linear(ref))


def is_linear(ref: Any) -> bool:
    """Whether an image reference reads c / 255 rather than sRGB-decoding: its ``encoding`` where
    the scene gives one (issue #22), else its use's default (``linear``: map_d, metallic-roughness)."""
    encoding = getattr(ref, "encoding", None)
    return encoding == "linear" if encoding is not None else bool(getattr(ref, "linear", False))


def build_texture(ref: Any):
    """The shading-side texture of a reference: an image loaded (with its UV map) or a
    checkerboard."""
    from ..shading.checkerboard import Checkerboard
    from ..shading.texture import load_texture

    if isinstance(ref, CheckerboardTexture):
        return Checkerboard(tuple(ref.color0), tuple(ref.color1), affine_of(ref))
    alpha = getattr(ref, "channel", "rgb") == "alpha"
    linear = alpha or is_linear(ref)
    return load_texture(ref.file, ref.wrap, ref.filter, affine_of(ref), linear=linear, alpha=alpha)


class NormalMap(StrictModel):
    """A tangent-space normal map (mcpt/shading/normal_map.py): an RGB image read LINEARLY (8 bits,
    c / 255, no sRGB curve), texel c -> normal (2c - 1) in the frame (T, B, N) of the mesh's UVs
    (T along increasing u, B along increasing v: the image's up, OpenGL / glTF / Blender)."""

    file: Path
    """Image file (PNG, ...; 16-bit is rounded to 8), relative to the scene file's folder."""
    scale: Annotated[float, Field(ge=0.0, le=100.0)] = 1.0
    """Factor on the map's x and y before normalising (glTF's normalTexture.scale); 0: flat."""
    handedness: Literal["uv", "right"] = "uv"
    """``uv``: B's side from the UV layout, per vertex (MikkTSpace: mirrored UVs work); ``right``:
    B = N x T always (Mitsuba's normalmap frame)."""
    wrap: Literal["repeat", "clamp", "mirror"] = "repeat"
    filter: Literal["bilinear", "nearest"] = "bilinear"
    uv: UvTransform | None = None

    @field_validator("file", mode="before")
    @classmethod
    def _resolve(cls, value: Any, info: ValidationInfo) -> Any:
        return texture_file(value, info)


def normal_map_shorthand(value: Any) -> Any:
    """``normal_map: bumps.png`` is short for ``normal_map: {file: bumps.png}``."""
    return {"file": value} if isinstance(value, (str, Path)) else value


def build_normal_map(ref: NormalMap):
    """The normal map's texture (linear), refused in one line if it is no normal map."""
    from ..shading.normal_map import check_normal_map
    from ..shading.texture import load_texture

    texture = load_texture(ref.file, ref.wrap, ref.filter, affine_of(ref), linear=True)
    check_normal_map(texture)
    return texture


class BumpMap(StrictModel):
    """A bump map (mcpt/shading/bump_map.py): a height image (a texel's height is its luminance)
    whose bilinear gradient tilts the normal, Mitsuba's ``bumpmap``."""

    file: Path
    """Image file, relative to the scene file's folder."""
    scale: Annotated[float, Field(ge=-1e3, le=1e3)] = 1.0
    """World units per unit of height (the image's values in [0, 1]); negative: dents."""
    encoding: Literal["linear", "srgb"] = "linear"
    """``linear``: height c / 255 (Mitsuba's raw=true); ``srgb``: sRGB-decoded (raw=false)."""
    wrap: Literal["repeat", "clamp", "mirror"] = "repeat"

    @field_validator("file", mode="before")
    @classmethod
    def _resolve(cls, value: Any, info: ValidationInfo) -> Any:
        return texture_file(value, info)


def build_bump_map(ref: BumpMap):
    """The bump map's height texture (bilinear: the gradient needs it)."""
    from ..shading.texture import load_texture

    return load_texture(ref.file, ref.wrap, "bilinear", linear=ref.encoding == "linear")


class ImageTexture(StrictModel):
    """An image used as a colour (mcpt/shading/texture.py), addressed by the mesh's UVs.

    8-bit images are sRGB-encoded and decoded to linear RGB (``encoding``); EXR / HDR / 16-bit
    images are float textures (mcpt/shading/float_texture.py); the alpha channel is ignored. UV
    (0, 0) is the image's bottom-left corner (OBJ convention: v points up).
    """

    file: Path
    """Image file (PNG, JPEG, ... read by OpenCV), relative to the scene file's folder."""
    wrap: Literal["repeat", "clamp", "mirror"] = "repeat"
    """What UVs outside [0, 1] read: the tiled image, the edge texels, or the mirrored image."""
    filter: Literal["bilinear", "nearest"] = "bilinear"
    """Bilinear interpolation of the four nearest texels (in linear RGB), or the nearest texel."""
    uv: UvTransform | None = None
    """A transform of the UVs before the lookup (mcpt/scene/textures.py)."""
    channel: Literal["rgb", "alpha"] = "rgb"
    """``alpha``: the image's alpha channel (linear; 1 where it has none) as a grey texture, for
    ``opacity`` (glTF's base colour alpha)."""
    encoding: Literal["srgb", "linear"] | None = None
    """How an 8/16-bit image's values are read (issue #22): ``srgb`` decoded by the sRGB curve,
    ``linear`` c / 255 (c / 65535). Default: ``srgb`` for albedo, emission, opacity and
    specular_reflectance, ``linear`` for metallic_roughness_texture. EXR / HDR are linear
    whatever it says (Mitsuba's float bitmaps); an alpha channel is linear."""

    @field_validator("file", mode="before")
    @classmethod
    def _resolve(cls, value: Any, info: ValidationInfo) -> Any:
        return texture_file(value, info)


class RoughnessTexture(ImageTexture):
    """A roughness texture (issue #22, mcpt/shading/roughness_texture.py): its first channel (a grey
    image's grey) times the material's ``roughness`` is the microfacet alpha at each hit, floored at
    the least alpha the material takes (0.001) and at most 1."""

    encoding: Literal["linear", "srgb"] = "linear"
    """``linear``: texel c / 255 (a roughness map is data, not colour); ``srgb``: sRGB-decoded, what
    Mitsuba 3's bitmap does without ``raw=true`` (the Mitsuba reader sets it)."""


def texture_shorthand(value: Any) -> Any:
    """``albedo_texture: spot.png`` is short for ``albedo_texture: {file: spot.png}``."""
    return {"file": value} if isinstance(value, (str, Path)) else value


def texture(value: Any, info: ValidationInfo) -> Any:
    """A texture: a file name or ``{file, ...}`` (an image), or ``{type: checkerboard, ...}``."""
    if value is None or isinstance(value, (ImageTexture, CheckerboardTexture)):
        return value
    return colour_or_texture(value, info, colours=False)


def colour_or_texture(value: Any, info: ValidationInfo, colours: bool = True) -> Any:
    """``specular_reflectance``: a number is a grey, a list an RGB colour, a string or a mapping an
    image texture (or a checkerboard). Validated here, so that an error speaks of the one form
    that was written."""
    if colours and isinstance(value, (int, float)) and not isinstance(value, bool):
        value = [value] * 3
    try:
        if colours and isinstance(value, (list, tuple)):
            return TypeAdapter(Albedo).validate_python(value, strict=True)
        kind = CheckerboardTexture if is_checkerboard(value) else ImageTexture
        return TypeAdapter(kind).validate_python(texture_shorthand(value), context=info.context)
    except ValidationError as exc:
        err = exc.errors()[0]
        where = "".join(f"item {p}: " if isinstance(p, int) else f"{p}: " for p in err["loc"])
        raise PydanticCustomError("colour_or_texture", "{msg}", {"msg": f"{where}{err['msg']}"}) from None

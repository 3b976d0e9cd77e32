"""Scene description: a YAML file -> validated, immutable Python objects.

This module only *describes* a scene. It does not load meshes (it only checks that each mesh file
exists) and touches no GL. Everything the user can get wrong in a scene file is reported as one
:class:`SceneError` whose message is a single line::

    <file>:<line>: <dotted.key.path>: <what is wrong>

so an editor can jump to it. The line comes from a custom YAML loader that remembers where every
mapping key and sequence item was written; pydantic's error location (``loc``) is mapped back onto
it.

Units and conventions (see /work/shared/scenes-ref/*/scene.json ``conventions``):

* Coordinates are right-handed, y up, arbitrary world units.
* Colours are linear RGB. ``albedo`` is a reflectance in [0, 1]; ``emission`` is emitted radiance
  (W sr^-1 m^-2), front side only.
* Angles in the file are degrees.

Public API: :class:`SceneError`, :func:`load_scene`, :func:`parse_scene`, and the models
:class:`Scene`, :class:`Camera`, :class:`RenderSettings`, :class:`Material`, :class:`Mesh`,
:class:`Transform`.
"""

from __future__ import annotations

import difflib
import math
import re
import types
import typing
from types import MappingProxyType
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
import yaml
from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationError,
    ValidationInfo,
    WrapSerializer,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from .camera import orthonormal

__all__ = [
    "MAX_RESOLUTION",
    "Camera",
    "Absorption",
    "ImageTexture",
    "Material",
    "Mesh",
    "RenderSettings",
    "Scene",
    "SceneError",
    "Transform",
    "load_scene",
    "parse_scene",
]

#: Largest accepted image width / height in pixels (GL textures are limited to this on most GPUs).
MAX_RESOLUTION = 16384


# ---------------------------------------------------------------------------------------------
# Error type
# ---------------------------------------------------------------------------------------------


class SceneError(Exception):
    """A problem in a scene file, as one line ``<file>:<line>: <key.path>: <what is wrong>``.

    ``line`` (1-based) is ``None`` when no line is known (e.g. a bad override that came from the
    command line); ``key`` is ``""`` for problems of the file as a whole (malformed YAML, empty file).
    The parts are kept as attributes so callers can format differently if they want.
    """

    def __init__(self, file: str | Path, line: int | None, key: str, reason: str) -> None:
        self.file = str(file)
        self.line = line
        self.key = key
        # One line, always: the message is meant to be printed as a compiler-style diagnostic.
        self.reason = " ".join(str(reason).split())
        where = self.file if line is None else f"{self.file}:{line}"
        parts = [where] + ([key] if key else []) + [self.reason]
        super().__init__(": ".join(parts))

    def __reduce__(self):  # keep pickling working despite the custom __init__ signature
        return (type(self), (self.file, self.line, self.key, self.reason))


class _FieldError(ValueError):
    """Raised inside a validator to blame a sub-field (``path``) instead of the whole model.

    pydantic only knows the location of the validator that raised; cross-field checks run on the
    parent model, so they carry the real culprit here and :func:`_to_scene_error` appends it.
    """

    def __init__(self, path: tuple[str | int, ...], message: str) -> None:
        super().__init__(message)
        self.path = path


# ---------------------------------------------------------------------------------------------
# Field types
# ---------------------------------------------------------------------------------------------


def _fixed_list(n: int, what: str = "numbers"):
    """Before-validator: accept a YAML list (or tuple) of exactly ``n`` items, hand on a tuple.

    Strict pydantic rejects lists for tuple fields, and we want tuples so the models are truly
    immutable (and hashable); the length check here also gives a clearer message than pydantic's
    per-index "Field required".
    """

    def check(value: Any) -> Any:
        if isinstance(value, (list, tuple)):
            if len(value) != n:
                raise PydanticCustomError(
                    "wrong_length",
                    "expected a list of {n} {what}, got {got} item(s)",
                    {"n": n, "what": what, "got": len(value)},
                )
            return tuple(value)
        raise PydanticCustomError(
            "not_a_list",
            "expected a list of {n} {what}, got {type}",
            {"n": n, "what": what, "type": _type_name(value)},
        )

    return BeforeValidator(check)


#: Any finite float (ints are accepted and widened: strict mode still allows int -> float).
Vec3 = Annotated[tuple[float, float, float], _fixed_list(3)]
#: Linear RGB reflectance, each channel in [0, 1].
Albedo = Annotated[
    tuple[
        Annotated[float, Field(ge=0.0, le=1.0)],
        Annotated[float, Field(ge=0.0, le=1.0)],
        Annotated[float, Field(ge=0.0, le=1.0)],
    ],
    _fixed_list(3),
]
#: Linear RGB radiance, each channel >= 0.
# Radiance is uploaded as float32: a larger value would become inf on the GPU.
_FLOAT32_MAX = float(np.finfo(np.float32).max)
Radiance = Annotated[
    tuple[
        Annotated[float, Field(ge=0.0, le=_FLOAT32_MAX)],
        Annotated[float, Field(ge=0.0, le=_FLOAT32_MAX)],
        Annotated[float, Field(ge=0.0, le=_FLOAT32_MAX)],
    ],
    _fixed_list(3),
]
_Pixels = Annotated[int, Field(ge=1, le=MAX_RESOLUTION)]
Resolution = Annotated[tuple[_Pixels, _Pixels], _fixed_list(2, "integers")]
_Row4 = Annotated[tuple[float, float, float, float], _fixed_list(4)]
Matrix4 = Annotated[tuple[_Row4, _Row4, _Row4, _Row4], _fixed_list(4, "rows")]


def _scalar_to_vec3(value: Any) -> Any:
    """``scale: 2`` means ``[2, 2, 2]``; a list is left for the Vec3 validator."""
    if isinstance(value, bool):  # bool is an int subclass; strict mode must still refuse it
        raise PydanticCustomError("scale_kind", "expected a number or a list of 3 numbers, got bool")
    if isinstance(value, (int, float)):
        if not math.isfinite(value):
            raise PydanticCustomError("finite_number", "Input should be a finite number")
        return (value, value, value)
    if isinstance(value, (list, tuple)):
        return value
    raise PydanticCustomError(
        "scale_kind", "expected a number or a list of 3 numbers, got {type}", {"type": _type_name(value)}
    )


def _list_to_tuple(value: Any) -> Any:
    """Before-validator for variable-length lists: strict mode wants tuples for tuple fields."""
    return tuple(value) if isinstance(value, list) else value


def _none_is_absent(default_factory):
    """Before-validator: an empty YAML section (``render:`` with everything commented out) is None;
    treat it like the section being absent rather than as a type error."""

    def check(value: Any) -> Any:
        return default_factory() if value is None else value

    return BeforeValidator(check)


class _Model(BaseModel):
    """Common config: no unknown keys, no silent coercion, no inf/nan, immutable."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, frozen=True)


# ---------------------------------------------------------------------------------------------
# Models
# ---------------------------------------------------------------------------------------------


class Camera(_Model):
    """Pinhole camera.

    Rays follow scene.json's ``camera_ray`` convention: ``f = normalize(look_at - position)``,
    ``r = normalize(cross(f, up))``, ``u = cross(r, f)``; image row 0 is the top.
    """

    position: Vec3
    """Eye position, world units."""
    look_at: Vec3
    """Point the camera looks at, world units; must differ from ``position``."""
    up: Vec3 = (0.0, 1.0, 0.0)
    """Up hint, world units (any length); must not be parallel to the view direction."""
    vfov_deg: Annotated[float, Field(gt=0.0, lt=180.0)]
    """Full vertical field of view in degrees, 0 < vfov_deg < 180."""
    resolution: Resolution
    """``[width, height]`` in pixels, each 1..MAX_RESOLUTION."""

    @property
    def width(self) -> int:
        """Image width in pixels."""
        return self.resolution[0]

    @property
    def height(self) -> int:
        """Image height in pixels."""
        return self.resolution[1]

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Orthonormal ``(forward, right, up)`` vectors (float64), per the convention above."""
        return orthonormal(self.position, self.look_at, self.up)

    @model_validator(mode="after")
    def _check_geometry(self) -> Camera:
        f = np.subtract(self.look_at, self.position, dtype=np.float64)
        f_len = float(np.linalg.norm(f))
        if f_len == 0.0:
            raise _FieldError(("look_at",), "look_at equals position, so there is no view direction")
        up = np.asarray(self.up, dtype=np.float64)
        up_len = float(np.linalg.norm(up))
        if up_len == 0.0:
            raise _FieldError(("up",), "up is the zero vector")
        # sin of the angle between the two; below ~1e-6 rad the right vector is numerically garbage.
        if np.linalg.norm(np.cross(f / f_len, up / up_len)) < 1e-6:
            raise _FieldError(("up",), "up is parallel to the view direction (look_at - position)")
        return self


class RenderSettings(_Model):
    """Render defaults; each can be overridden from the command line (:meth:`Scene.with_overrides`)."""

    spp: Annotated[int, Field(ge=1)] = 64
    """Samples per pixel, >= 1."""
    bounces: Annotated[int, Field(ge=0)] = 8
    """Maximum scattering events per path: 0 = emitters only, 1 = direct light only."""
    seed: Annotated[int, Field(ge=0, lt=2**63)] = 0
    """Random seed, 0 <= seed < 2**63 (fits a signed 64-bit integer)."""


#: 8-bit image formats OpenCV reads for textures (mcpt/textures.py); others are refused here.
TEXTURE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")


def _scene_path(value: Any, info: ValidationInfo, what: str = "a file path") -> Path:
    """A path from the scene file: relative ones are relative to the scene file's folder (passed
    as validation context), so a scene renders the same whatever the working directory."""
    if isinstance(value, str):
        if not value:
            raise PydanticCustomError("empty_path", "file is an empty string")
        value = Path(value)
    elif not isinstance(value, Path):
        raise PydanticCustomError(
            "path_kind", "expected {what} (string), got {type}", {"what": what, "type": _type_name(value)}
        )
    base = (info.context or {}).get("base_dir")
    if not value.is_absolute() and base is not None:
        value = Path(base) / value
    return value.resolve()


def _texture_file(value: Any, info: ValidationInfo) -> Any:
    """A texture path: relative to the scene file's folder, must be an existing image file."""
    value = _scene_path(value, info, "an image file path")
    if not value.is_file():
        raise PydanticCustomError("texture_missing", "texture file not found: {path}", {"path": str(value)})
    if value.suffix.lower() not in TEXTURE_SUFFIXES:
        raise PydanticCustomError(
            "texture_kind", "unsupported texture format {suffix!r} (use one of {ok})",
            {"suffix": value.suffix, "ok": ", ".join(TEXTURE_SUFFIXES)},
        )
    return value


class ImageTexture(_Model):
    """An image used as a colour (mcpt/textures.py), addressed by the mesh's UVs.

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
    """A surface material (GLSL: glsl/bsdf_<type>.glsl; table: mcpt/materials.py).

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


class Transform(_Model):
    """Placement of a mesh: either translate/rotate/scale, or a full ``matrix``.

    Points are column vectors, ``p' = M p``, with ``M = T · Rz · Ry · Rx · S``: scale first, then
    rotate about X, then Y, then Z (all about the origin), then translate.
    """

    translate: Vec3 | None = None
    """Offset, world units."""
    rotate_deg: Vec3 | None = None
    """Euler angles in degrees, applied about X, then Y, then Z (right-handed, counter-clockwise)."""
    scale: Annotated[Vec3, BeforeValidator(_scalar_to_vec3)] | None = None
    """Uniform factor or ``[sx, sy, sz]``; every factor nonzero (negative mirrors the mesh)."""
    rows: Matrix4 | None = Field(default=None, alias="matrix")
    """YAML key ``matrix``: 4x4 row-major affine matrix, last row ``[0, 0, 0, 1]``; excludes the
    three above. (Stored as ``rows`` because :meth:`matrix` is the composed result.)"""

    @model_validator(mode="after")
    def _check(self) -> Transform:
        if self.rows is not None:
            both = [k for k in ("translate", "rotate_deg", "scale") if getattr(self, k) is not None]
            if both:
                raise _FieldError(("matrix",), f"matrix cannot be combined with {', '.join(both)}")
            m = np.asarray(self.rows, dtype=np.float64)
            if not np.array_equal(m[3], [0.0, 0.0, 0.0, 1.0]):
                # Projective matrices would break normals and area-light sampling; affine only.
                raise _FieldError(("matrix", 3), f"last row must be [0, 0, 0, 1], got {m[3].tolist()}")
            a = m[:3, :3]
            # Relative test, so a legitimately tiny (but well-conditioned) scale is still accepted.
            if abs(np.linalg.det(a)) <= 1e-12 * max(float(np.abs(a).max()), 1e-300) ** 3:
                raise _FieldError(("matrix",), "matrix is singular (its 3x3 part has zero determinant)")
        if self.scale is not None and 0.0 in self.scale:
            # A zero factor flattens the mesh: degenerate triangles, undefined normals.
            raise _FieldError(("scale",), f"scale must be nonzero, got {list(self.scale)}")
        return self

    def matrix(self) -> np.ndarray:
        """The 4x4 float64 object-to-world matrix (a fresh array; identity if nothing is set)."""
        if self.rows is not None:
            return np.array(self.rows, dtype=np.float64)
        t = np.eye(4)
        if self.translate is not None:
            t[:3, 3] = self.translate
        r = np.eye(4)
        if self.rotate_deg is not None:
            ax, ay, az = np.radians(self.rotate_deg)
            r[:3, :3] = _rot_z(az) @ _rot_y(ay) @ _rot_x(ax)
        s = np.eye(4)
        if self.scale is not None:
            s[:3, :3] = np.diag(self.scale)
        return t @ r @ s


def _rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class Mesh(_Model):
    """One OBJ file placed in the scene."""

    file: Path
    """Absolute path of the OBJ. In YAML: relative to the YAML file's folder, or absolute."""
    material: str | None = None
    """Name of an entry of ``Scene.materials``; None = use the OBJ's own MTL materials."""
    transform: Transform = Transform()
    """Object-to-world placement; identity when absent."""

    @field_validator("file", mode="before")
    @classmethod
    def _resolve(cls, value: Any, info: ValidationInfo) -> Any:
        return _scene_path(value, info)

    @field_validator("file", mode="after")
    @classmethod
    def _exists(cls, value: Path) -> Path:
        if not value.exists():
            raise ValueError(f"mesh file not found: {value}")
        if not value.is_file():
            raise ValueError(f"mesh file is not a regular file: {value}")
        return value

    @field_validator("transform", mode="before")
    @classmethod
    def _empty_transform(cls, value: Any) -> Any:
        return Transform() if value is None else value


class Scene(_Model):
    """The root of a scene file. Build it with :func:`load_scene` / :func:`parse_scene`."""

    name: str | None = None
    """Free-form scene name (for logs / output names)."""
    camera: Camera
    render: Annotated[RenderSettings, _none_is_absent(RenderSettings)] = RenderSettings()
    """Render defaults (spp 64, bounces 8, seed 0)."""
    materials: Annotated[
        dict[str, Material],
        _none_is_absent(dict),
        # Read-only view, so the frozen Scene is immutable all the way down.
        AfterValidator(MappingProxyType),
        WrapSerializer(lambda value, handler: handler(dict(value))),
    ] = Field(default_factory=lambda: MappingProxyType({}))
    """Material name -> material (a read-only mapping)."""
    meshes: Annotated[tuple[Mesh, ...], BeforeValidator(_list_to_tuple), Field(min_length=1)]
    """The meshes, at least one (required)."""

    _source: Path | None = PrivateAttr(default=None)

    @model_validator(mode="after")
    def _check_material_names(self) -> Scene:
        for i, mesh in enumerate(self.meshes):
            if mesh.material is not None and mesh.material not in self.materials:
                defined = ", ".join(sorted(self.materials)) or "none"
                raise _FieldError(
                    ("meshes", i, "material"),
                    f"undefined material {mesh.material!r} (defined: {defined})",
                )
        return self

    @property
    def source_path(self) -> Path | None:
        """The YAML file this scene was read from (None if built otherwise)."""
        return self._source

    def with_overrides(
        self,
        *,
        spp: int | None = None,
        bounces: int | None = None,
        seed: int | None = None,
        resolution: tuple[int, int] | list[int] | None = None,
    ) -> Scene:
        """A new, fully revalidated Scene with the given render settings / resolution replaced.

        ``None`` keeps the file's value. Raises :class:`SceneError` (no line number) if an override
        is invalid, e.g. ``spp=0``.
        """
        # Untouched sub-models are passed as instances (already valid, immutable); the changed
        # ones are rebuilt from plain data so every constraint is checked again.
        render = self.render.model_dump()
        for key, value in (("spp", spp), ("bounces", bounces), ("seed", seed)):
            if value is not None:
                render[key] = value
        camera = self.camera.model_dump()
        if resolution is not None:
            camera["resolution"] = resolution
        data = {
            "name": self.name,
            "camera": camera,
            "render": render,
            "materials": dict(self.materials),
            "meshes": self.meshes,
        }
        source = self._source if self._source is not None else "<scene>"
        try:
            scene = Scene.model_validate(data)
        except ValidationError as exc:
            raise _to_scene_error(exc, source, {}, note="(override)") from None
        scene._source = self._source
        return scene



# ---------------------------------------------------------------------------------------------
# YAML loading with line numbers
# ---------------------------------------------------------------------------------------------

#: A key path as pydantic reports it, stringified: ("meshes", "2", "material").
_KeyPath = tuple[str, ...]


class _SceneLoader(yaml.SafeLoader):
    """SafeLoader that knows where things are, refuses duplicate keys and reads ``1e3`` as a float.

    Usage: :meth:`compose_indexed` composes the node tree and fills :attr:`lines`; the normal
    ``construct_document`` then builds plain Python data from it.
    """

    def __init__(self, stream: str, file: str) -> None:
        super().__init__(stream)
        self.file = file
        #: key path -> 1-based line of the mapping key / sequence item; () -> the document start.
        self.lines: dict[_KeyPath, int] = {}

    def compose_indexed(self) -> yaml.Node | None:
        """The document's root node (None for an empty document), with :attr:`lines` filled."""
        node = self.get_single_node()
        if node is not None:
            self.lines[()] = node.start_mark.line + 1
            self._index(node, (), set())
        return node

    def _index(self, node: yaml.Node, path: _KeyPath, seen: set[int]) -> None:
        # An alias is the *same* node object as its anchor: walk it once, which keeps the walk
        # linear (no "billion laughs") and finite for recursive aliases. Keys under an alias then
        # fall back to the line where the alias is used, which is where the user should look.
        if id(node) in seen:
            return
        seen.add(id(node))
        if isinstance(node, yaml.SequenceNode):
            for i, item in enumerate(node.value):
                self.lines[path + (str(i),)] = item.start_mark.line + 1
                self._index(item, path + (str(i),), seen)
        elif isinstance(node, yaml.MappingNode):
            first: dict[tuple[str, str], int] = {}
            merges = []
            for key_node, value_node in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":  # "<<: *base" — own keys win
                    merges.append(value_node)
                    continue
                if key_node.tag == "tag:yaml.org,2002:bool" and key_node.style is None:
                    # YAML 1.1 reads a plain `on:`/`yes:` key as True; every key here is a name.
                    key_node.tag = "tag:yaml.org,2002:str"
                key = self._key_text(key_node)
                line = key_node.start_mark.line + 1
                ident = (key_node.tag, key)  # "spp" and spp are the same key; 1 and "1" are not
                if ident in first:
                    raise SceneError(
                        self.file, line, _dotted(path + (key,)),
                        f"duplicate key {key!r} (first defined on line {first[ident]})",
                    )
                first[ident] = line
                self.lines[path + (key,)] = line
                self._index(value_node, path + (key,), seen)
            for merged in merges:
                for source in merged.value if isinstance(merged, yaml.SequenceNode) else [merged]:
                    if isinstance(source, yaml.MappingNode):
                        for key_node, _ in source.value:
                            self.lines.setdefault(path + (self._key_text(key_node),), key_node.start_mark.line + 1)

    @staticmethod
    def _key_text(key_node: yaml.Node) -> str:
        # Keys are compared with pydantic's loc via str(); complex keys just get a readable tag.
        return key_node.value if isinstance(key_node, yaml.ScalarNode) else f"<{key_node.id} key>"


# YAML 1.1 (PyYAML) needs a dot in a float and a sign in its exponent, so "1e3" and "1.0e3" would
# be *strings*; YAML 1.2 and every human read them as numbers. Integers still win for "123"
# because the int resolver was registered first.
_FLOAT_12 = re.compile(r"^[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?$")
_SceneLoader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT_12, list("-+.0123456789"))


def _dotted(path: tuple[Any, ...]) -> str:
    return ".".join(str(p) for p in path)


def _type_name(value: Any) -> str:
    return "null" if value is None else type(value).__name__


def _line_of(lines: dict[_KeyPath, int], loc: tuple[Any, ...]) -> int | None:
    """Line of the longest prefix of ``loc`` that was written in the file.

    A missing key has no line of its own, so it is blamed on its parent mapping's key.
    """
    for n in range(len(loc), -1, -1):
        line = lines.get(tuple(str(p) for p in loc[:n]))
        if line is not None:
            return line
    return None


def _model_at(loc: tuple[Any, ...]) -> type[BaseModel] | None:
    """The model class validating the mapping at ``loc`` (for listing allowed keys), if any."""
    model: type[BaseModel] = Scene
    i = 0
    while i < len(loc):
        field = next(
            (f for name, f in model.model_fields.items() if (f.alias or name) == loc[i]), None
        )
        if field is None:
            return None
        ann = field.annotation
        if typing.get_origin(ann) in (typing.Union, types.UnionType):  # X | None
            ann = next(a for a in typing.get_args(ann) if a is not type(None))
        step = 1
        if typing.get_origin(ann) in (tuple, list, dict):  # skip the index / dict key in loc
            ann = typing.get_args(ann)[-1 if typing.get_origin(ann) is dict else 0]
            step = 2
        if not (isinstance(ann, type) and issubclass(ann, BaseModel)):
            return None
        model, i = ann, i + step
    return model


def _describe(err: dict[str, Any], loc: tuple[Any, ...]) -> str:
    """A friendlier one-line message for one pydantic error dict."""
    kind, value = err["type"], err.get("input")
    if kind == "value_error" and "error" in err.get("ctx", {}):
        return str(err["ctx"]["error"])
    if kind == "missing":
        return "required key is missing"
    if kind == "extra_forbidden":
        model = _model_at(loc[:-1])
        if model is None:
            return f"unknown key {loc[-1]!r}"
        allowed = [f.alias or name for name, f in model.model_fields.items()]
        close = difflib.get_close_matches(str(loc[-1]), allowed, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        return f"unknown key {loc[-1]!r} (allowed: {', '.join(allowed)}){hint}"
    msg = err["msg"]
    if kind.endswith("_type") or kind in ("finite_number", "is_instance_of"):
        # Show what was actually read: "abc" (str), True (bool), 1000.0 (float from 1e3) ...
        shown = repr(value)
        shown = shown if len(shown) <= 40 else shown[:37] + "..."
        msg = f"{msg}, got {_type_name(value)} {shown}"
        if kind == "int_type" and isinstance(value, float) and value.is_integer():
            msg += f" (write {int(value)}: an exponent or decimal point makes a float)"
    return msg


def _to_scene_error(
    exc: ValidationError, file: str | Path, lines: dict[_KeyPath, int], note: str = ""
) -> SceneError:
    """The first pydantic error as a :class:`SceneError` pointing at the file's line."""
    err = exc.errors()[0]
    loc = tuple(err["loc"])
    cause = err.get("ctx", {}).get("error")
    if isinstance(cause, _FieldError):  # a cross-field check blamed a specific sub-field
        loc += cause.path
    reason = _describe(err, loc) + (f" {note}" if note else "")
    return SceneError(file, _line_of(lines, loc) if lines else None, _dotted(loc), reason)


def parse_scene(text: str, path: str | Path) -> Scene:
    """Parse and validate scene YAML ``text``; ``path`` names the file (for messages) and its
    folder anchors relative mesh paths. Raises :class:`SceneError`."""
    path = Path(path)
    file = str(path)
    loader = _SceneLoader(text, file)
    try:
        try:
            node = loader.compose_indexed()
            data = None if node is None else loader.construct_document(node)
        except yaml.MarkedYAMLError as exc:
            mark = exc.problem_mark or exc.context_mark
            line = mark.line + 1 if mark else None
            what = exc.problem or "syntax error"
            if exc.context:  # e.g. "while parsing a flow sequence", which may have begun earlier
                started = exc.context_mark.line + 1 if exc.context_mark else line
                where = f" (started on line {started})" if started != line else ""
                what = f"{exc.context}{where}: {what}"
            kind = "unsupported YAML" if isinstance(exc, yaml.constructor.ConstructorError) else "malformed YAML"
            raise SceneError(file, line, "", f"{kind}: {what}") from None
        except yaml.YAMLError as exc:  # e.g. a reader error on a control character
            raise SceneError(file, None, "", f"malformed YAML: {exc}") from None
    finally:
        loader.dispose()
    if node is None:
        raise SceneError(file, 1, "", "the file is empty (expected a mapping with camera and meshes)")
    if not isinstance(data, dict):
        raise SceneError(
            file, loader.lines.get(()), "",
            f"the top level must be a mapping (camera:, meshes:, ...), got {_type_name(data)}",
        )
    try:
        scene = Scene.model_validate(data, context={"base_dir": path.parent.resolve()})
    except ValidationError as exc:
        raise _to_scene_error(exc, file, loader.lines) from None
    scene._source = path
    return scene


def load_scene(path: str | Path) -> Scene:
    """Read and validate the scene file at ``path``. Raises :class:`SceneError`."""
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8-sig")  # tolerate a BOM
    except OSError as exc:
        raise SceneError(path, None, "", f"cannot read scene file: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise SceneError(path, None, "", f"not UTF-8 text (byte {exc.start})") from None
    return parse_scene(text, path)

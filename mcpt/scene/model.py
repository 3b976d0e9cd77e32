"""Scene models: camera, render settings, meshes and the scene root, validated and immutable.

This module only *describes* a scene. It does not load meshes (it only checks that each mesh file
exists) and touches no GL. Everything the user can get wrong in a scene file is reported as one
:class:`SceneError` whose message is a single line::

    <file>:<line>: <dotted.key.path>: <what is wrong>

so an editor can jump to it. The line comes from a custom YAML loader that remembers where every
mapping key and sequence item was written; pydantic's error location (``loc``) is mapped back onto
it.

Units and conventions (the same as the Mitsuba reference scenes mcpt is compared against):

* Coordinates are right-handed, y up, arbitrary world units.
* Colours are linear RGB. ``albedo`` is a reflectance in [0, 1]; ``emission`` is emitted radiance
  (W sr^-1 m^-2), front side only.
* Angles in the file are degrees.

Public API: :class:`SceneError`, :func:`load_scene`, :func:`parse_scene`, and the models
:class:`Scene`, :class:`Camera`, :class:`RenderSettings`, :class:`Material`, :class:`Mesh`,
:class:`Transform`.
"""

from __future__ import annotations

from pathlib import Path
from types import MappingProxyType
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (
    AfterValidator,
    BeforeValidator,
    Field,
    PrivateAttr,
    ValidationError,
    ValidationInfo,
    WrapSerializer,
    field_validator,
    model_validator,
)

from ..shading.camera import orthonormal, vertical_fov
from .animation import Animation, check_scene, origin
from .diagnostics import FieldError, dotted, line_of, to_scene_error
from .fields import Resolution, StrictModel, Vec3, list_to_tuple, none_is_absent, scene_path
from .lens import Lens
from .lights import Environment, Light
from .materials import Material
from .medium import Medium, check_delta_lights
from .pixel_filter import FilterField, PixelFilter
from .transform import Transform


class Camera(StrictModel):
    """Camera: pinhole (default), thin lens (``lens``) or orthographic (``projection``); its pixel
    filter (``filter``). glsl/camera.glsl traces the rays.

    Rays follow scene.json's ``camera_ray`` convention: ``f = normalize(look_at - position)``,
    ``r = normalize(cross(f, up))``, ``u = cross(r, f)``; image row 0 is the top.
    """

    position: Vec3
    """Eye position, world units."""
    look_at: Vec3
    """Point the camera looks at, world units; must differ from ``position``."""
    up: Vec3 = (0.0, 1.0, 0.0)
    """Up hint, world units (any length); must not be parallel to the view direction."""
    vfov_deg: Annotated[float, Field(gt=0.0, lt=180.0)] | None = None
    """Full vertical field of view in degrees, 0 < vfov_deg < 180 (perspective: this or ``fov_deg``)."""
    fov_deg: Annotated[float, Field(gt=0.0, lt=180.0)] | None = None
    """Full field of view in degrees along ``fov_axis``, instead of ``vfov_deg`` (which it sets)."""
    fov_axis: Literal["x", "y", "diagonal", "smaller", "larger"] | None = None
    """The axis ``fov_deg`` spans, as Mitsuba's ``fov_axis`` (default ``x``, Mitsuba's)."""
    projection: Literal["perspective", "orthographic"] = "perspective"
    """``orthographic``: parallel rays along the view direction over ``ortho_height``."""
    ortho_height: Annotated[float, Field(gt=0.0)] | None = None
    """Orthographic only: full height of the view in world units (the width follows the aspect)."""
    resolution: Resolution
    """``[width, height]`` in pixels, each 1..MAX_RESOLUTION."""
    filter: FilterField = PixelFilter()
    """Pixel filter (mcpt/scene/pixel_filter.py): ``box`` (default), ``tent``, ``gaussian`` or a
    mapping ``{type: gaussian, stddev: 0.5}``; drawn by filter importance sampling."""
    lens: Lens | None = None
    """Thin lens (mcpt/scene/lens.py): depth of field; absent: a pinhole."""

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
            raise FieldError(("look_at",), "look_at equals position, so there is no view direction")
        up = np.asarray(self.up, dtype=np.float64)
        up_len = float(np.linalg.norm(up))
        if up_len == 0.0:
            raise FieldError(("up",), "up is the zero vector")
        # sin of the angle between the two; below ~1e-6 rad the right vector is numerically garbage.
        if np.linalg.norm(np.cross(f / f_len, up / up_len)) < 1e-6:
            raise FieldError(("up",), "up is parallel to the view direction (look_at - position)")
        return self._check_projection()

    def _check_projection(self) -> Camera:
        if self.fov_axis is not None and self.fov_deg is None:
            raise FieldError(("fov_axis",), "fov_axis goes with fov_deg")
        if self.projection == "perspective":
            if self.fov_deg is not None:
                if self.vfov_deg is not None:
                    raise FieldError(("fov_deg",), "give vfov_deg or fov_deg (with fov_axis), not both")
                vfov = vertical_fov(self.fov_deg, self.fov_axis or "x", self.width / self.height)
                object.__setattr__(self, "vfov_deg", vfov)  # frozen: set once, here
            if self.vfov_deg is None:
                raise FieldError(("vfov_deg",), "required key is missing (a perspective camera's field of view)")
            if self.ortho_height is not None:
                raise FieldError(("ortho_height",), "ortho_height is for projection: orthographic")
            return self
        if self.ortho_height is None:
            raise FieldError(("ortho_height",), "required key is missing (an orthographic camera's view height)")
        for key in ("vfov_deg", "fov_deg", "lens"):
            if getattr(self, key) is not None:
                raise FieldError((key,), f"{key} is for a perspective camera, not an orthographic one")
        return self


class RenderSettings(StrictModel):
    """Render defaults; each can be overridden from the command line (:meth:`Scene.with_overrides`)."""

    spp: Annotated[int, Field(ge=1, le=2**32 - 1)] = 64
    """Samples per pixel, 1 .. 2^32 - 1 (the sample index is 32-bit: mcpt/shading/sobol.py)."""
    bounces: Annotated[int, Field(ge=0, le=2**24 - 1)] = 8
    """Maximum scattering events per path: 0 = emitters only, 1 = direct light only; at most
    2^24 - 1 (issue #24: the shader keeps the bounce index k <= bounces + 1 in a float32 texel
    between draws, exact up to 2^24, and a 32-bit int; beyond, paths silently ended at once)."""
    seed: Annotated[int, Field(ge=0, lt=2**63)] = 0
    """Random seed, 0 <= seed < 2**63 (fits a signed 64-bit integer)."""
    transparent: bool = False
    """Transparent film (issue #20): camera rays that leave the scene see nothing and the image
    gets an alpha channel (the share of each pixel's camera rays that hit something; EXR ``A``,
    PNG alpha), for compositing over a plate; the environment still lights the scene."""



class Mesh(StrictModel):
    """One mesh file (or, issue #19, an analytic ``shape``) placed in the scene."""

    file: Path | None = None
    """Absolute path of the OBJ (any Assimp format, or a Mitsuba ``.serialized``). In YAML:
    relative to the YAML file's folder, or absolute. Exactly one of ``file`` and ``shape``."""
    # --- issue #19 (Mitsuba 3 scenes): analytic shapes, .serialized shapes, flipped fronts ---
    shape: Literal["rectangle", "cube", "disk", "sphere", "cylinder"] | None = None
    """An analytic shape in Mitsuba's own frame, tessellated (mcpt/shapes/primitives.py):
    rectangle [-1,1]^2 at z=0 facing +z, cube [-1,1]^3, unit disk at z=0, unit sphere, open unit
    cylinder 0<=z<=1; placed by ``transform``."""
    shape_index: Annotated[int, Field(ge=0)] | None = None
    """Which shape of a ``.serialized`` file (default 0); of a ``.gltf``/``.glb`` file, which
    primitive (file order across its meshes), in its mesh's own frame (absent: the whole file,
    placed by its nodes)."""
    flip_normals: bool = False
    """Turn the front side round (reversed winding): Mitsuba's ``flip_normals``."""

    @model_validator(mode="after")
    def _one_source(self) -> Mesh:
        if (self.file is None) == (self.shape is None):
            raise FieldError(("file",), "give a mesh file or a shape (exactly one)")
        indexed = (".serialized", ".gltf", ".glb")  # issue #19: glTF primitives too
        if self.shape_index is not None and (self.file is None or self.file.suffix.lower() not in indexed):
            raise FieldError(("shape_index",), "shape_index is for .serialized and glTF files only")
        return self
    # --- end issue #19 ---
    material: str | None = None
    """Name of an entry of ``Scene.materials``; None = use the OBJ's own MTL materials."""
    transform: Transform = Transform()
    """Object-to-world placement; identity when absent."""

    @field_validator("file", mode="before")
    @classmethod
    def _resolve(cls, value: Any, info: ValidationInfo) -> Any:
        return scene_path(value, info)

    @field_validator("file", mode="after")
    @classmethod
    def _exists(cls, value: Path | None) -> Path | None:
        if value is None:  # issue #19: a shape instead of a file
            return value
        if not value.exists():
            raise ValueError(f"mesh file not found: {value}")
        if not value.is_file():
            raise ValueError(f"mesh file is not a regular file: {value}")
        return value

    @field_validator("transform", mode="before")
    @classmethod
    def _empty_transform(cls, value: Any) -> Any:
        return Transform() if value is None else value


class Scene(StrictModel):
    """The root of a scene file. Build it with :func:`load_scene` / :func:`parse_scene`."""

    name: str | None = None
    """Free-form scene name (for logs / output names)."""
    camera: Camera
    render: Annotated[RenderSettings, none_is_absent(RenderSettings)] = RenderSettings()
    """Render defaults (spp 64, bounces 8, seed 0)."""
    materials: Annotated[
        dict[str, Material],
        none_is_absent(dict),
        # Read-only view, so the frozen Scene is immutable all the way down.
        AfterValidator(MappingProxyType),
        WrapSerializer(lambda value, handler: handler(dict(value))),
    ] = Field(default_factory=lambda: MappingProxyType({}))
    """Material name -> material (a read-only mapping)."""
    meshes: Annotated[tuple[Mesh, ...], BeforeValidator(list_to_tuple), Field(min_length=1)]
    """The meshes, at least one (required)."""
    lights: Annotated[tuple[Light, ...], none_is_absent(tuple), BeforeValidator(list_to_tuple)] = ()
    """Point, spot and directional lights (issue #20, mcpt/scene/lights.py), besides emissive meshes."""
    environment: Environment | None = None
    """The light of rays that leave the scene (issue #20); None: black."""
    medium: Medium | None = None
    """A homogeneous participating medium filling the scene (issue #25, mcpt/scene/medium.py); None: vacuum."""
    animation: Animation | None = None
    """Keyframes of the camera and mesh transforms (issue #26, mcpt/scene/animation.py)."""

    _source: Path | None = PrivateAttr(default=None)
    _lines: dict = PrivateAttr(default_factory=dict)  # key path (strings) -> line, from the reader

    @model_validator(mode="after")
    def _check_material_names(self) -> Scene:
        for i, mesh in enumerate(self.meshes):
            if mesh.material is not None and mesh.material not in self.materials:
                defined = ", ".join(sorted(self.materials)) or "none"
                raise FieldError(
                    ("meshes", i, "material"),
                    f"undefined material {mesh.material!r} (defined: {defined})",
                )
        if self.animation is not None:  # issue #26: animated meshes exist
            check_scene(self)
        check_delta_lights(self)  # issue #25: delta lights cannot cross an ior-1 medium boundary
        return self

    @property
    def origin(self) -> tuple:
        """Where the geometry is rebased (mcpt/shapes/world.py): the camera position, or an
        animation's rest pose (issue #26, mcpt/scene/animation.py origin)."""
        return origin(self)

    def located(self, source: Path, lines: dict) -> Scene:
        """This scene, told the file it was read from and the line of every key (the reader's
        ``KeyPath -> line`` map), for :meth:`where`. Returns ``self``."""
        self._source = source
        self._lines = dict(lines)
        return self

    @property
    def source_path(self) -> Path | None:
        """The YAML file this scene was read from (None if built otherwise)."""
        return self._source

    def where(self, *key) -> str:
        """``file:line: key.path`` of a key of this scene, for errors found after validation
        (a mesh that Assimp cannot read, a texture that is not an image)."""
        line = line_of(self._lines, key) if self._lines else None
        file = str(self._source) if self._source is not None else "<scene>"
        return f"{file}:{line}: {dotted(key)}" if line else f"{file}: {dotted(key)}"

    def line(self, *key) -> int | None:
        """The line of exactly this key, where the reader recorded one (None otherwise)."""
        return self._lines.get(tuple(str(k) for k in key))

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
        if camera["fov_deg"] is not None:
            camera["vfov_deg"] = None  # derived from fov_deg and the (new) aspect again
        if resolution is not None:
            camera["resolution"] = resolution
        data = {
            "name": self.name,
            "camera": camera,
            "render": render,
            "materials": dict(self.materials),
            "meshes": self.meshes,
            "lights": self.lights,
            "environment": self.environment,
            "medium": self.medium,
            "animation": self.animation,
        }
        source = self._source if self._source is not None else "<scene>"
        try:
            scene = Scene.model_validate(data)
        except ValidationError as exc:
            raise to_scene_error(exc, source, {}, Scene, note="(override)") from None
        scene._source = self._source
        scene._lines = self._lines
        return scene


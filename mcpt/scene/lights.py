"""Lights that are not surfaces, as the scene file states them (issue #20; GPU side:
mcpt/shading/light_punctual.py <-> glsl/light_punctual.glsl, mcpt/shading/environment.py <->
glsl/environment.glsl).

A scene's ``lights:`` is a list of punctual lights, each a mapping with a ``type``:

* ``point``: ``position``, ``intensity`` (RGB, W sr^-1): Mitsuba 3's ``point``.
* ``spot``: ``position``, ``look_at`` (or ``direction``), ``intensity`` (RGB, W sr^-1 on the
  axis), ``cutoff_deg`` (default 20) and ``beam_deg`` (default 3/4 of the cutoff): Mitsuba 3's
  ``spot``. The intensity is full inside the beam and falls off linearly in angle to 0 at the
  cutoff (src/emitters/spot.cpp ``falloff_curve``: (cutoff - theta) / (cutoff - beam)).
* ``directional``: ``direction`` (the way the light travels) and ``irradiance`` (RGB, W m^-2 on
  a surface facing the light): Mitsuba 3's ``directional``, a sun at infinity. With
  ``angular_diameter_deg`` > 0 it is a sun disk of that apparent size, of uniform radiance
  E / (pi sin^2(diameter / 2)) so that a surface facing it still receives E (the sun: 0.53).

Point, spot and directional lights are delta lights: no ray can hit them, next-event estimation
alone finds them. A sun disk is not: rays that leave the scene towards it see it (MIS).

``environment:`` is the light of everything a ray that leaves the scene sees: ``radiance`` (RGB,
W sr^-1 m^-2) for a constant sky (Mitsuba 3's ``constant``), or ``file`` for an equirectangular
HDR image (Mitsuba 3's ``envmap``: mcpt/shading/envmap.py gives the orientation, +Y up) with a
radiance ``scale`` and a ``transform`` that turns it (a rotation: ``rotate_deg`` or ``matrix``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field, ValidationInfo, field_validator, model_validator

from .diagnostics import FieldError
from .fields import Radiance, StrictModel, Vec3, scene_path
from .transform import Transform

#: Which keys each light type takes (``type`` aside).
LIGHT_KEYS = {
    "point": ("position", "intensity"),
    "spot": ("position", "look_at", "direction", "intensity", "cutoff_deg", "beam_deg"),
    "directional": ("direction", "irradiance", "angular_diameter_deg"),
}
_REQUIRED = {"point": ("position", "intensity"), "spot": ("position", "intensity"),
             "directional": ("direction", "irradiance")}
_Angle = Annotated[float, Field(gt=0.0, le=90.0)]


class Light(StrictModel):
    """One punctual light (module docstring); positions in world units, angles in degrees."""

    type: Literal["point", "spot", "directional"]
    """point, spot or directional."""
    position: Vec3 | None = None
    """Where a point or spot light is, world units."""
    look_at: Vec3 | None = None
    """Spot: the point its axis aims at (or give ``direction``)."""
    direction: Vec3 | None = None
    """Directional: the direction the light travels; spot: its axis (instead of ``look_at``)."""
    intensity: Radiance | None = None
    """Point, spot: radiant intensity, linear RGB, W sr^-1 (spot: on its axis)."""
    irradiance: Radiance | None = None
    """Directional: irradiance on a surface facing the light, linear RGB, W m^-2."""
    cutoff_deg: _Angle | None = None
    """Spot: half-angle of the cone outside which it is dark, degrees (default 20)."""
    beam_deg: _Angle | None = None
    """Spot: half-angle of the full-intensity beam, degrees (default 3/4 of the cutoff)."""
    angular_diameter_deg: Annotated[float, Field(ge=0.0, le=90.0)] | None = None
    """Directional: apparent diameter of the sun disk, degrees (0 or absent: a delta light)."""

    @model_validator(mode="after")
    def _check(self) -> Light:
        allowed = LIGHT_KEYS[self.type]
        for key in ("position", "look_at", "direction", "intensity", "irradiance", "cutoff_deg", "beam_deg",
                    "angular_diameter_deg"):
            if getattr(self, key) is not None and key not in allowed:
                raise FieldError((key,), f"a {self.type} light has no {key} (it takes: {', '.join(allowed)})")
        for key in _REQUIRED[self.type]:
            if getattr(self, key) is None:
                raise FieldError((key,), f"a {self.type} light needs {key}")
        power_key = "irradiance" if self.type == "directional" else "intensity"
        if max(getattr(self, power_key)) <= 0.0:
            raise FieldError((power_key,), f"{power_key} is zero: the light gives no light")
        if self.type == "spot":
            if (self.look_at is None) == (self.direction is None):
                raise FieldError(("look_at",), "a spot light needs look_at or direction (exactly one)")
            if self.beam_deg is not None and self.beam_deg > self.cutoff:
                raise FieldError(("beam_deg",), f"beam_deg {self.beam_deg:g} exceeds cutoff_deg {self.cutoff:g}")
        if self.type != "point" and float(np.linalg.norm(self.axis)) == 0.0:
            raise FieldError(("direction" if self.direction is not None else "look_at",),
                             "the light's direction is the zero vector")
        return self

    @property
    def cutoff(self) -> float:
        """Spot cutoff half-angle, degrees (Mitsuba's default 20)."""
        return 20.0 if self.cutoff_deg is None else self.cutoff_deg

    @property
    def beam(self) -> float:
        """Spot beam half-angle, degrees (Mitsuba's default: 3/4 of the cutoff)."""
        return 0.75 * self.cutoff if self.beam_deg is None else self.beam_deg

    @property
    def axis(self) -> np.ndarray:
        """Unit direction the light shines along (spot axis, directional travel), float64."""
        if self.direction is not None:
            d = np.asarray(self.direction, np.float64)
        else:
            d = np.subtract(self.look_at, self.position, dtype=np.float64)
        n = float(np.linalg.norm(d))
        return d / n if n > 0 else d


class Environment(StrictModel):
    """The light from outside the scene, seen by every ray that leaves it."""

    radiance: Radiance | None = None
    """Constant environment: radiance from every direction, linear RGB, W sr^-1 m^-2."""
    file: Path | None = None
    """Environment map: an equirectangular image (.exr, .hdr; .png/.jpg read as sRGB), relative to
    the scene file's folder. Exactly one of ``radiance`` and ``file``."""
    scale: Annotated[float, Field(gt=0.0)] = 1.0
    """Environment map: factor on its radiance (Mitsuba's ``scale``)."""
    transform: Transform = Transform()
    """Environment map: its orientation in the world (Mitsuba's ``to_world``), a rotation."""
    visible: bool = True
    """Camera rays that leave the scene see it (False: they see black, the scene is still lit)."""

    @field_validator("file", mode="before")
    @classmethod
    def _resolve(cls, value: Any, info: ValidationInfo) -> Any:
        if value is None:
            return value
        path = scene_path(value, info, "an image file path")
        if not path.is_file():
            raise ValueError(f"environment map not found: {path}")
        return path

    @model_validator(mode="after")
    def _check(self) -> Environment:
        if (self.radiance is None) == (self.file is None):
            raise FieldError(("radiance",), "give radiance (a constant sky) or file (an environment map), exactly one")
        if self.radiance is not None:
            for key in ("scale", "transform"):
                if key in self.model_fields_set:
                    raise FieldError((key,), f"{key} is for an environment map (file), not a constant radiance")
            if max(self.radiance) <= 0.0:
                raise FieldError(("radiance",), "radiance is zero: the environment gives no light")
        return self

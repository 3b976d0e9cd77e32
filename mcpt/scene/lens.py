"""The camera's thin lens in a scene file (``camera.lens``): depth of field as Mitsuba 3's
``thinlens`` sensor (src/sensors/thinlens.cpp) has it. Rays start on a disk of radius
``aperture_radius`` around the camera position, perpendicular to the view direction, and pass
through the point of the plane ``focus_distance`` ahead that the pinhole ray of the same film
position reaches: that plane stays sharp (glsl/camera.glsl, mcpt/shading/camera.py)."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, model_validator

from .diagnostics import FieldError
from .fields import StrictModel

_Positive = Annotated[float, Field(gt=0.0)]


class Lens(StrictModel):
    """``{focus_distance, aperture_radius}`` or ``{focus_distance, f_number, focal_length}``, all
    lengths in world units along the view direction."""

    focus_distance: _Positive
    """Distance of the plane in focus from the camera, world units (> 0)."""
    aperture_radius: Annotated[float, Field(ge=0.0)] | None = None
    """Radius of the lens aperture, world units (0: a pinhole)."""
    f_number: _Positive | None = None
    """With ``focal_length``: aperture diameter = focal_length / f_number (the field of view
    stays ``vfov_deg``; the focal length sets only the aperture)."""
    focal_length: _Positive | None = None
    """Lens focal length in world units (e.g. 0.05 for 50 mm in a scene in metres)."""

    @model_validator(mode="after")
    def _one_aperture(self) -> Lens:
        by_ratio = self.f_number is not None or self.focal_length is not None
        if by_ratio and self.aperture_radius is not None:
            raise FieldError(("aperture_radius",), "give aperture_radius or f_number with "
                             "focal_length, not both")
        if by_ratio and (self.f_number is None or self.focal_length is None):
            missing = "focal_length" if self.focal_length is None else "f_number"
            raise FieldError((missing,), f"f_number and focal_length go together: {missing} is missing")
        if not by_ratio and self.aperture_radius is None:
            raise FieldError(("aperture_radius",), "a lens needs aperture_radius (or f_number and "
                             "focal_length)")
        return self

    @property
    def radius(self) -> float:
        """The aperture radius, world units."""
        if self.aperture_radius is not None:
            return self.aperture_radius
        return self.focal_length / (2.0 * self.f_number)

    def describe(self) -> str:
        return f"thin lens (aperture radius {self.radius:g}, focus distance {self.focus_distance:g})"

"""The camera's pixel filter in a scene file (``camera.filter``); sampled by
mcpt/shading/pixel_filter.py, which describes the filters (Mitsuba 3's box, tent, gaussian)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, Field, model_validator

from ..shading.pixel_filter import GAUSS_STDDEV, TENT_RADIUS, radius
from .diagnostics import FieldError
from .fields import StrictModel

#: Largest filter radius accepted, pixels: wider is a blur, not a pixel filter (and a typo).
MAX_RADIUS = 16.0


def _name_is_type(value: Any) -> Any:
    """``filter: gaussian`` means ``filter: {type: gaussian}``."""
    return {"type": value} if isinstance(value, str) else value


class PixelFilter(StrictModel):
    """``box`` (default: each sample uniform in its pixel), ``tent`` or ``gaussian``."""

    type: Literal["box", "tent", "gaussian"] = "box"
    stddev: Annotated[float, Field(gt=0.0)] | None = None
    """Gaussian only: standard deviation in pixels (default 0.5, Mitsuba's); radius 4 stddev."""
    radius: Annotated[float, Field(gt=0.0)] | None = None
    """Tent only: radius in pixels (default 1, Mitsuba's)."""

    @model_validator(mode="after")
    def _check(self) -> PixelFilter:
        if self.stddev is not None and self.type != "gaussian":
            raise FieldError(("stddev",), f"stddev is for the gaussian filter, not {self.type}")
        if self.radius is not None and self.type != "tent":
            raise FieldError(("radius",), f"radius is for the tent filter, not {self.type} "
                             "(the gaussian's is 4 stddev)")
        if self.support > MAX_RADIUS:
            key = "stddev" if self.type == "gaussian" else "radius"
            raise FieldError((key,), f"filter radius {self.support:g} px exceeds {MAX_RADIUS:g} px")
        return self

    @property
    def std(self) -> float:
        return GAUSS_STDDEV if self.stddev is None else self.stddev

    @property
    def tent_radius(self) -> float:
        return TENT_RADIUS if self.radius is None else self.radius

    @property
    def support(self) -> float:
        """Radius of the filter's support, pixels."""
        return radius(self.type, self.std, self.tent_radius)

    def describe(self) -> str:
        if self.type == "gaussian":
            return f"gaussian (stddev {self.std:g} px, radius {self.support:g} px)"
        if self.type == "tent":
            return f"tent (radius {self.tent_radius:g} px)"
        return "box"


FilterField = Annotated[PixelFilter, BeforeValidator(_name_is_type)]

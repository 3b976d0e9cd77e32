"""Field types shared by the scene models: fixed-length lists, colours, paths, the strict base model."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import numpy as np
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationInfo
from pydantic_core import PydanticCustomError

from .diagnostics import type_name

#: Largest accepted image width / height in pixels (GL textures are limited to this on most GPUs).
MAX_RESOLUTION = 16384


def fixed_list(n: int, what: str = "numbers"):
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
            {"n": n, "what": what, "type": type_name(value)},
        )

    return BeforeValidator(check)


#: Any finite float (ints are accepted and widened: strict mode still allows int -> float).
Vec3 = Annotated[tuple[float, float, float], fixed_list(3)]
#: Linear RGB reflectance, each channel in [0, 1].
Albedo = Annotated[
    tuple[
        Annotated[float, Field(ge=0.0, le=1.0)],
        Annotated[float, Field(ge=0.0, le=1.0)],
        Annotated[float, Field(ge=0.0, le=1.0)],
    ],
    fixed_list(3),
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
    fixed_list(3),
]
_Pixels = Annotated[int, Field(ge=1, le=MAX_RESOLUTION)]
Resolution = Annotated[tuple[_Pixels, _Pixels], fixed_list(2, "integers")]
_Row4 = Annotated[tuple[float, float, float, float], fixed_list(4)]
Matrix4 = Annotated[tuple[_Row4, _Row4, _Row4, _Row4], fixed_list(4, "rows")]


def scalar_to_vec3(value: Any) -> Any:
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
        "scale_kind", "expected a number or a list of 3 numbers, got {type}", {"type": type_name(value)}
    )


def list_to_tuple(value: Any) -> Any:
    """Before-validator for variable-length lists: strict mode wants tuples for tuple fields."""
    return tuple(value) if isinstance(value, list) else value


def none_is_absent(default_factory):
    """Before-validator: an empty YAML section (``render:`` with everything commented out) is None;
    treat it like the section being absent rather than as a type error."""

    def check(value: Any) -> Any:
        return default_factory() if value is None else value

    return BeforeValidator(check)


class StrictModel(BaseModel):
    """Common config: no unknown keys, no silent coercion, no inf/nan, immutable."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, frozen=True)



#: 8-bit image formats OpenCV reads for textures (mcpt/shading/texture.py); others are refused here.
TEXTURE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp", ".exr", ".hdr")


def scene_path(value: Any, info: ValidationInfo, what: str = "a file path") -> Path:
    """A path from the scene file: relative ones are relative to the scene file's folder (passed
    as validation context), so a scene renders the same whatever the working directory."""
    if isinstance(value, str):
        if not value:
            raise PydanticCustomError("empty_path", "file is an empty string")
        value = Path(value)
    elif not isinstance(value, Path):
        raise PydanticCustomError(
            "path_kind", "expected {what} (string), got {type}", {"what": what, "type": type_name(value)}
        )
    base = (info.context or {}).get("base_dir")
    if not value.is_absolute() and base is not None:
        value = Path(base) / value
    return value.resolve()


def texture_file(value: Any, info: ValidationInfo) -> Any:
    """A texture path: relative to the scene file's folder, must be an existing image file."""
    value = scene_path(value, info, "an image file path")
    if not value.is_file():
        raise PydanticCustomError("texture_missing", "texture file not found: {path}", {"path": str(value)})
    if value.suffix.lower() not in TEXTURE_SUFFIXES:
        # pydantic's templates know {name} only, not {name!r}: quote here.
        raise PydanticCustomError(
            "texture_kind", "unsupported texture format {suffix} (use one of {ok})",
            {"suffix": repr(value.suffix or "(none)"), "ok": ", ".join(TEXTURE_SUFFIXES)},
        )
    return value

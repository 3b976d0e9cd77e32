"""Scene errors as one line ``<file>:<line>: <key.path>: <what is wrong>``.

pydantic reports an error location (``loc``); the reader (mcpt/scene/reader.py) remembers the line of
every key, and this module maps one onto the other and words the message for a person.
"""

from __future__ import annotations

import difflib
import reprlib
import types
import typing
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from ..errors import McptError

#: A key path as pydantic reports it, stringified: ("meshes", "2", "material").
KeyPath = tuple[str, ...]


#: Longest reason a SceneError prints (characters); longer ones are cut in the middle.
MAX_REASON = 300

# Bounded repr of what was read: never formats an unbounded value (a YAML alias bomb expands to
# 9^9 items; formatting it all took 50 s and 3 GB before the message was cut).
_REPR = reprlib.Repr()
_REPR.maxstring, _REPR.maxother, _REPR.maxlist, _REPR.maxtuple, _REPR.maxdict, _REPR.maxlevel = 40, 40, 4, 4, 4, 2


def clip(text: str, limit: int) -> str:
    """``text`` cut to at most ``limit`` characters, the cut marked with an ellipsis."""
    if len(text) <= limit:
        return text
    head = (limit - 1) * 2 // 3
    return text[:head] + "…" + text[len(text) - (limit - 1 - head):]


def shown(value: Any) -> str:
    """A short repr of a value read from the file, whatever its size."""
    return _REPR.repr(value)


class SceneError(McptError):
    """A problem in a scene file, as one line ``<file>:<line>: <key.path>: <what is wrong>``.

    ``line`` (1-based) is ``None`` when no line is known (e.g. a bad override that came from the
    command line); ``key`` is ``""`` for problems of the file as a whole (malformed YAML, empty file).
    The parts are kept as attributes so callers can format differently if they want.
    """

    def __init__(self, file: str | Path, line: int | None, key: str, reason: str) -> None:
        self.file = str(file)
        self.line = line
        self.key = key
        # One line, always: the message is meant to be printed as a compiler-style diagnostic,
        # and bounded (a 30 000-character name must not come back whole).
        self.reason = clip(" ".join(str(reason).split()), MAX_REASON)
        where = self.file if line is None else f"{self.file}:{line}"
        parts = [where] + ([key] if key else []) + [self.reason]
        super().__init__(": ".join(parts))

    def __reduce__(self):  # keep pickling working despite the custom __init__ signature
        return (type(self), (self.file, self.line, self.key, self.reason))


class FieldError(ValueError):
    """Raised inside a validator to blame a sub-field (``path``) instead of the whole model.

    pydantic only knows the location of the validator that raised; cross-field checks run on the
    parent model, so they carry the real culprit here and :func:`to_scene_error` appends it.
    """

    def __init__(self, path: tuple[str | int, ...], message: str) -> None:
        super().__init__(message)
        self.path = path



def dotted(path: tuple[Any, ...]) -> str:
    return ".".join(str(p) for p in path)


def type_name(value: Any) -> str:
    return "null" if value is None else type(value).__name__


def line_of(lines: dict[KeyPath, int], loc: tuple[Any, ...]) -> int | None:
    """Line of the longest prefix of ``loc`` that was written in the file.

    A missing key has no line of its own, so it is blamed on its parent mapping's key.
    """
    for n in range(len(loc), -1, -1):
        line = lines.get(tuple(str(p) for p in loc[:n]))
        if line is not None:
            return line
    return None


def _model_at(loc: tuple[Any, ...], root: type[BaseModel]) -> type[BaseModel] | None:
    """The model class validating the mapping at ``loc`` under the ``root`` model (for listing
    allowed keys), if any."""
    model: type[BaseModel] = root
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


def _describe(err: dict[str, Any], loc: tuple[Any, ...], root: type[BaseModel],
              missing: tuple[str, ...] = ()) -> str:
    """A friendlier one-line message for one pydantic error dict."""
    kind, value = err["type"], err.get("input")
    if kind == "value_error" and "error" in err.get("ctx", {}):
        return str(err["ctx"]["error"])
    if kind == "missing":
        return "required key is missing"
    if kind == "extra_forbidden":
        model = _model_at(loc[:-1], root)
        if model is None:
            return f"unknown key {shown(loc[-1])}"
        allowed = [f.alias or name for name, f in model.model_fields.items()]
        # A required key missing from the same mapping is the likeliest meaning of a typo
        # ("fov" for vfov_deg), even where the spelling is too far off for difflib.
        close = difflib.get_close_matches(str(loc[-1]), list(missing) or allowed, n=1, cutoff=0.0 if missing else 0.6)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        return f"unknown key {shown(loc[-1])} (allowed: {', '.join(allowed)}){hint}"
    msg = err["msg"]
    if kind.endswith("_type") or kind in ("finite_number", "is_instance_of"):
        # Show what was actually read: "abc" (str), True (bool), 1000.0 (float from 1e3) ...
        msg = f"{msg}, got {type_name(value)} {shown(value)}"
        if kind == "int_type" and isinstance(value, float) and value.is_integer():
            msg += f" (write {int(value)}: an exponent or decimal point makes a float)"
    return msg


def to_scene_error(
    exc: ValidationError, file: str | Path, lines: dict[KeyPath, int], root: type[BaseModel], note: str = ""
) -> SceneError:
    """The first pydantic error as a :class:`SceneError` pointing at the file's line; ``root`` is
    the model that was validated (the Scene), whose fields name the allowed keys.

    An unknown key is reported before a missing one: a misspelt key causes both, and the
    misspelling is what the user has to fix (with the missing key as the suggestion).
    """
    errors = exc.errors()
    extra = [e for e in errors if e["type"] == "extra_forbidden"]
    err = extra[0] if extra else errors[0]
    loc = tuple(err["loc"])
    missing = tuple(str(e["loc"][-1]) for e in errors
                    if e["type"] == "missing" and tuple(e["loc"][:-1]) == loc[:-1])
    cause = err.get("ctx", {}).get("error")
    if isinstance(cause, FieldError):  # a cross-field check blamed a specific sub-field
        loc += cause.path
    reason = _describe(err, loc, root, missing) + (f" {note}" if note else "")
    return SceneError(file, line_of(lines, loc) if lines else None, dotted(loc), reason)

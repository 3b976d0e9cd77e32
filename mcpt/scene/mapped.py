"""A scene mapped from another format (Mitsuba 3 XML, glTF 2.0) onto mcpt's schema becomes a
Scene the way a YAML file does: ``-D`` key overrides applied to the data, then the same
validation, its first error one line naming the source file and, where the format has them, the
line (mcpt/scene/diagnostics.py)."""

from __future__ import annotations

from pathlib import Path

from pydantic import ValidationError

from .diagnostics import to_scene_error
from .model import Scene
from .overrides import apply as apply_overrides
from .overrides import blame


def validated(data: dict, lines: dict, path: Path, keys: list) -> Scene:
    """The Scene of mapped ``data`` (``lines``: key path -> source line, may be empty; ``keys``:
    parsed ``-D KEY=VALUE`` overrides of the mapped data). Raises SceneError (one line)."""
    named, original = [], data
    if keys:
        data, named = apply_overrides(data, keys, str(path))
    context = {"base_dir": path.parent.resolve()}
    try:
        scene = Scene.model_validate(data, context=context)
    except ValidationError as exc:
        raise blame(to_scene_error(exc, str(path), lines, Scene), named, str(path), original,
                    lambda d: Scene.model_validate(d, context=context)) from None
    return scene.located(path, lines)

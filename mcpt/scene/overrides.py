"""``-D KEY=VALUE``: command-line overrides of any scene key, validated like the file.

``KEY`` is a dotted path into the YAML document (``camera.resolution``, ``materials.white.albedo``,
``meshes.0.material``: a number indexes a list); ``VALUE`` is read as YAML (``[512,512]``, ``0.8``,
``glass``). Overrides are applied to the file's data BEFORE validation, so a value is checked by
the same rules as if it were in the file, and an error about an overridden key names the override
instead of a line of the file.
"""

from __future__ import annotations

import copy

import yaml

from .diagnostics import SceneError


def parse(text: str, source: str) -> tuple[tuple[str, ...], object]:
    key, sep, value = text.partition("=")
    path = tuple(k.strip() for k in key.split("."))
    if not sep or not key.strip() or any(not k for k in path):
        raise SceneError(source, None, "", f"-D {text}: expected KEY=VALUE with a dotted KEY, "
                         "e.g. -D camera.resolution=[512,512]")
    try:
        parsed = yaml.safe_load(value) if value.strip() else None
    except yaml.YAMLError as exc:
        what = getattr(exc, "problem", None) or "syntax error"
        raise SceneError(source, None, ".".join(path), f"-D {text}: malformed YAML value: {what}") from None
    return path, parsed


def apply(data: dict, overrides, source: str) -> tuple[dict, list]:
    """A copy of ``data`` with the overrides set; and [(path, text)] for naming them in errors."""
    data = copy.deepcopy(data)
    named = []
    for text in overrides:
        path, value = parse(text, source)
        node = data
        for i, k in enumerate(path):
            last = i == len(path) - 1
            if isinstance(node, list):
                if not k.isdigit() or int(k) >= len(node):
                    raise SceneError(source, None, ".".join(path),
                                     f"-D {text}: {'.'.join(path[:i]) or 'the list'} has {len(node)} "
                                     f"items, no item {k!r}")
                k = int(k)
            elif not isinstance(node, dict):
                raise SceneError(source, None, ".".join(path),
                                 f"-D {text}: {'.'.join(path[:i])} is not a mapping")
            if last:
                node[k] = value
            else:
                if isinstance(node, dict) and not isinstance(node.get(k), (dict, list)):
                    node[k] = {}
                node = node[k]
        named.append((path, text))
    return data, named


def blame(err: SceneError, named: list, source: str) -> SceneError:
    """``err`` re-worded to name the override behind it, if one is."""
    key = tuple(err.key.split(".")) if err.key else ()
    for path, text in reversed(named):
        n = min(len(path), len(key))
        if key and path[:n] == key[:n]:
            return SceneError(source, None, err.key, f"-D {text}: {err.reason}")
    return err

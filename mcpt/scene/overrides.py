"""``-D KEY=VALUE``: command-line overrides of any scene key, validated like the file.

``KEY`` is a dotted path into the YAML document (``camera.resolution``, ``materials.white.albedo``,
``meshes.0.material``: a number indexes a list); ``VALUE`` is read as YAML (``[512,512]``, ``0.8``,
``glass``) by the scene reader's rules (yaml12.py: ``4e1`` is a float). Overrides are applied to
the file's data BEFORE validation, so a value is checked by the same rules as if it were in the
file, and an error about an overridden key names the override instead of a line of the file; an
error elsewhere that an override caused (``-D materials=`` leaves a mesh's material undefined)
names the override too (issue #24 item 19).
"""

from __future__ import annotations

import copy

import yaml

from .diagnostics import SceneError
from .yaml12 import load_value


def parse(text: str, source: str) -> tuple[tuple[str, ...], object]:
    key, sep, value = text.partition("=")
    path = tuple(k.strip() for k in key.split("."))
    if not sep or not key.strip() or any(not k for k in path):
        raise SceneError(source, None, "", f"-D {text}: expected KEY=VALUE with a dotted KEY, "
                         "e.g. -D camera.resolution=[512,512]")
    try:
        parsed = load_value(value) if value.strip() else None
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


def blame(err: SceneError, named: list, source: str, original=None, check=None) -> SceneError:
    """``err`` re-worded to name the override behind it, if one is: the override of its key, else
    (given the file's ``original`` data and ``check``, which raises on data that does not
    validate) the first override whose application makes the data fail."""
    key = tuple(err.key.split(".")) if err.key else ()
    for path, text in reversed(named):
        n = min(len(path), len(key))
        if key and path[:n] == key[:n]:
            return SceneError(source, None, err.key, f"-D {text}: {err.reason}")
    text = _culprit(original, [t for _, t in named], source, check) if check is not None else None
    if text is not None:
        return SceneError(err.file, err.line, err.key, f"after -D {text}: {err.reason}")
    return err


def _culprit(original, texts: list, source: str, check) -> str | None:
    """The first of ``texts`` whose override turns data that validates into data that does not;
    None if the file fails without them (its own error) or none does. Runs on the error path only."""
    for i in range(len(texts) + 1):
        try:
            check(apply(original, texts[:i], source)[0])
        except Exception:  # noqa: BLE001 - any failure of validation counts
            return texts[i - 1] if i else None
    return None

"""glTF's ``KHR_texture_transform`` as mcpt's texture ``uv`` (mcpt/scene/textures.py).

The extension maps uv to T(offset) R(rotation) S(scale) uv with R = [[cos r, sin r], [-sin r,
cos r]] (rotation in radians, KHR_texture_transform/README.md), on glTF's UVs, whose v points down
the image. mcpt flips v when it reads TEXCOORD_0 (mcpt/scene/gltf/geometry.py) and its image rows,
so the same texel is read through F A F with F(u, v) = (u, 1 - v), as for Mitsuba's ``to_uv``.
"""

from __future__ import annotations

import math

import numpy as np

from .container import Gltf

FLIP = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 1.0], [0.0, 0.0, 1.0]])


def _numbers(g: Gltf, ext: dict, key: str, default: list[float], where: str) -> list[float]:
    value = ext.get(key, default)
    items = value if isinstance(value, list) else [value]
    if len(items) != len(default) or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in items):
        raise g.error(where, f"{key} {value!r} is not {len(default)} finite number(s)"[:200])
    return [float(x) for x in items]


def uv_of_khr_transform(g: Gltf, ext, where: str) -> dict:
    """``{"uv": {"matrix": ...}}`` for the extension object ``ext`` (nothing for the identity)."""
    if not isinstance(ext, dict):
        raise g.error(where, "must be an object")
    if ext.get("texCoord", 0) != 0:
        raise g.error(where, f"texCoord {ext.get('texCoord')!r}: mcpt reads TEXCOORD_0 only")
    (ox, oy), (r,), (sx, sy) = (_numbers(g, ext, "offset", [0.0, 0.0], where),
                                _numbers(g, ext, "rotation", [0.0], where),
                                _numbers(g, ext, "scale", [1.0, 1.0], where))
    if sx == 0.0 or sy == 0.0:
        raise g.error(where, f"scale {[sx, sy]} flattens the texture")
    c, s = math.cos(r), math.sin(r)
    a = np.array([[1, 0, ox], [0, 1, oy], [0, 0, 1]]) @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]]) \
        @ np.diag([sx, sy, 1.0])
    m = FLIP @ a @ FLIP
    if np.allclose(m, np.eye(3), rtol=0.0, atol=1e-12):
        return {}
    return {"uv": {"matrix": [[float(x) for x in row] for row in m[:2]]}}

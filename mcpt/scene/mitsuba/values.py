"""Mitsuba 3 property values and ``to_world`` transforms, read from located XML elements.

Properties are the children ``<float|integer|boolean|string|rgb|spectrum|point|vector|transform
name=...>`` of an object; :func:`properties` collects them by name. A ``<transform>`` composes its
operations in file order, each new one LEFT-multiplying what came before (Mitsuba's
``Transform4f`` parser: ``M = op · M``), so ``<translate/>`` after ``<scale/>`` scales first.
"""

from __future__ import annotations

import logging
import math
import re

import numpy as np

from .xmltree import Node

log = logging.getLogger("mcpt")

PROPERTY_TAGS = ("float", "integer", "boolean", "string", "rgb", "spectrum", "point", "vector",
                 "transform", "color")
_SPLIT = re.compile(r"[,\s]+")


def floats(node: Node, text: str, n: int | None = None, what: str = "value") -> list[float]:
    """Numbers of ``text`` (comma or space separated); ``n``: the count required."""
    try:
        out = [float(t) for t in _SPLIT.split(text.strip()) if t]
    except ValueError:
        raise node.error(f"{what}={text!r} is not a list of numbers") from None
    if not all(math.isfinite(x) for x in out):
        raise node.error(f"{what}={text!r} is not finite")
    if n is not None and len(out) != n:
        raise node.error(f"{what}={text!r}: expected {n} numbers, got {len(out)}")
    return out


def _xyz(node: Node, default: float) -> list[float]:
    """A vector given as ``value="x, y, z"`` (or one number for all three) or as x/y/z attributes."""
    if "value" in node.attrs:
        v = floats(node, node.attrs["value"])
        if len(v) == 1:
            return v * 3
        if len(v) != 3:
            raise node.error(f"value={node.attrs['value']!r}: expected 1 or 3 numbers")
        return v
    return [floats(node, node.attrs.get(k, str(default)), 1, k)[0] for k in ("x", "y", "z")]


def _srgb_hex(node: Node, text: str) -> list[float] | None:
    if not text.startswith("#"):
        return None
    if len(text) != 7:
        raise node.error(f"value={text!r}: expected #RRGGBB")
    c = [int(text[i:i + 2], 16) / 255.0 for i in (1, 3, 5)]
    return [x / 12.92 if x <= 0.04045 else ((x + 0.055) / 1.055) ** 2.4 for x in c]


def rgb(node: Node) -> tuple[float, float, float]:
    """``<rgb value="r, g, b">`` (one number: grey; #RRGGBB: sRGB-decoded), linear RGB."""
    text = node.need("value")
    v = _srgb_hex(node, text) or floats(node, text)
    if len(v) == 1:
        v = v * 3
    if len(v) != 3:
        raise node.error(f"value={text!r}: expected 1 or 3 numbers")
    return (v[0], v[1], v[2])


def spectrum(node: Node) -> tuple[float, float, float]:
    """``<spectrum value="v">`` (constant) or ``value="l1:v1, l2:v2, ..."`` (nm: value pairs),
    the latter reduced to RGB by averaging over the three thirds of the visible range, with a
    one-line warning (mcpt renders in RGB)."""
    if "filename" in node.attrs:
        raise node.error("spectrum files are not supported by mcpt (give value=\"...\" or an <rgb>)")
    text = node.need("value").strip()
    if ":" not in text:
        v = floats(node, text)
        if len(v) != 1:
            raise node.error(f"value={text!r}: a constant spectrum is one number (use <rgb> for three)")
        return (v[0], v[0], v[0])
    pairs = []
    for item in _SPLIT.split(text):
        if not item:
            continue
        lam, sep, val = item.partition(":")
        try:
            pairs.append((float(lam), float(val)))
        except ValueError:
            raise node.error(f"value={text!r}: expected wavelength:value pairs") from None
    lam, val = np.array(sorted(pairs)).T
    # Blue 400-500 nm, green 500-600 nm, red 600-700 nm: the mean of the piecewise-linear spectrum.
    grid = np.linspace(400.0, 700.0, 301)
    s = np.interp(grid, lam, val)
    r, g, b = (float(s[(grid >= lo) & (grid <= lo + 100)].mean()) for lo in (600.0, 500.0, 400.0))
    log.warning("%s:%d: %s: a sampled spectrum is approximated by RGB (%.4g, %.4g, %.4g), the mean "
                "over 600-700, 500-600, 400-500 nm (mcpt renders in RGB)", node.file, node.line,
                node.label, r, g, b)
    return (r, g, b)


def _rotation(axis: np.ndarray, angle_deg: float) -> np.ndarray:
    """Rodrigues' formula c I + s [a]x + (1 - c) a a^T for ``angle_deg`` about ``axis`` (right-handed),
    4x4, with ``axis`` AS GIVEN: Mitsuba 3's ``Transform4f::rotate`` (include/mitsuba/core/transform.h)
    does not normalise it, so a non-unit axis also scales (checked on Mitsuba 3.9.1:
    rotate([0, 0, 2], 90) maps (1, 0, 0) to (0, 2, 0)); Mitsuba's own hello.xml rotates about (0, 1, 1)."""
    a = np.asarray(axis, np.float64)
    t = math.radians(angle_deg)
    c, s = math.cos(t), math.sin(t)
    x, y, z = a
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    m = np.eye(4)
    m[:3, :3] = c * np.eye(3) + s * k + (1.0 - c) * np.outer(a, a)
    return m


def look_at(origin, target, up) -> np.ndarray:
    """Mitsuba's ``Transform4f::look_at``: columns left = up x dir, up' = dir x left, dir, origin
    (the camera looks along its local +z; local +x is the image's LEFT)."""
    origin, target, up = (np.asarray(v, np.float64) for v in (origin, target, up))
    d = target - origin
    d = d / np.linalg.norm(d)
    left = np.cross(up, d)
    left = left / np.linalg.norm(left)
    new_up = np.cross(d, left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, new_up, d, origin
    return m


def transform(node: Node) -> np.ndarray:
    """The 4x4 float64 matrix of a ``<transform>`` element (see the module doc for the order)."""
    m = np.eye(4)
    for op in node.children:
        m = _operation(op) @ m
    if not np.isfinite(m).all():
        raise node.error("the transform is not finite")
    return m


def _operation(op: Node) -> np.ndarray:
    """The 4x4 matrix of one ``<translate|rotate|scale|matrix|lookat>``."""
    out = np.eye(4)
    if op.tag == "translate":
        out[:3, 3] = _xyz(op, 0.0)
    elif op.tag == "scale":
        s = _xyz(op, 1.0)
        if 0.0 in s:
            raise op.error(f"scale {s} flattens the shape")
        out[:3, :3] = np.diag(s)
    elif op.tag == "rotate":
        axis = np.array(_xyz(op, 0.0))
        if not axis.any():
            raise op.error("rotate needs a nonzero axis (x, y, z or value)")
        if abs(float(np.linalg.norm(axis)) - 1.0) > 1e-6:
            log.warning("%s:%d: %s: axis of length %.4g: Mitsuba (and mcpt, to match it) use it "
                        "unnormalised, which scales as well as rotates", op.file, op.line, op.label,
                        float(np.linalg.norm(axis)))
        out = _rotation(axis, floats(op, op.need("angle"), 1, "angle")[0])
    elif op.tag == "matrix":
        v = floats(op, op.need("value"))
        if len(v) == 9:
            out[:3, :3] = np.reshape(v, (3, 3))
        elif len(v) == 16:
            out = np.reshape(v, (4, 4))  # row-major, as Mitsuba reads it
        else:
            raise op.error(f"expected 9 or 16 numbers, got {len(v)}")
    elif op.tag == "lookat":
        origin = floats(op, op.need("origin"), 3, "origin")
        target = floats(op, op.need("target"), 3, "target")
        up = floats(op, op.get("up", "0, 1, 0"), 3, "up")
        d = np.subtract(target, origin)
        if not d.any():
            raise op.error("target equals origin: no view direction")
        if np.linalg.norm(np.cross(d / np.linalg.norm(d), up)) < 1e-9:
            raise op.error("up is parallel to the view direction")
        out = look_at(origin, target, up)
    else:
        raise op.error("not a transform operation (translate, rotate, scale, matrix, lookat)")
    return out


def properties(obj: Node) -> dict[str, Node]:
    """The property children of ``obj`` by ``name`` (objects and refs are left to the caller)."""
    out: dict[str, Node] = {}
    for child in obj.children:
        if child.tag in PROPERTY_TAGS:
            name = child.need("name")
            if name in out:
                raise child.error(f"property {name!r} given twice (first on line {out[name].line})")
            out[name] = child
    return out


def as_float(node: Node) -> float:
    if node.tag not in ("float", "integer"):
        raise node.error(f"expected a <float>, got <{node.tag}>")
    return floats(node, node.need("value"), 1)[0]


def as_int(node: Node) -> int:
    if node.tag != "integer":
        raise node.error(f"expected an <integer>, got <{node.tag}>")
    text = node.need("value").strip()
    try:
        return int(text)
    except ValueError:
        raise node.error(f"value={text!r} is not an integer") from None


def as_bool(node: Node) -> bool:
    if node.tag != "boolean":
        raise node.error(f"expected a <boolean>, got <{node.tag}>")
    text = node.need("value").strip().lower()
    if text not in ("true", "false"):
        raise node.error(f"value={text!r}: expected true or false")
    return text == "true"


def as_string(node: Node) -> str:
    if node.tag != "string":
        raise node.error(f"expected a <string>, got <{node.tag}>")
    return node.need("value")


def as_color(node: Node) -> tuple[float, float, float]:
    """A colour-valued property: <rgb>, <spectrum>, or a number (a grey)."""
    if node.tag in ("rgb", "color"):
        return rgb(node)
    if node.tag == "spectrum":
        return spectrum(node)
    if node.tag in ("float", "integer"):
        v = as_float(node)
        return (v, v, v)
    raise node.error(f"expected a colour (<rgb>, <spectrum> or <float>), got <{node.tag}>")


def as_point(node: Node) -> tuple[float, float, float]:
    if node.tag not in ("point", "vector"):
        raise node.error(f"expected a <point>, got <{node.tag}>")
    x, y, z = _xyz(node, 0.0)
    return (x, y, z)


def as_transform(node: Node) -> np.ndarray:
    if node.tag != "transform":
        raise node.error(f"expected a <transform>, got <{node.tag}>")
    return transform(node)

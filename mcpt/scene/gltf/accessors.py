"""glTF accessors read into numpy arrays (glTF 2.0 spec, section 3.6).

An accessor is ``count`` elements of ``type`` (SCALAR, VEC2, VEC3, VEC4) made of ``componentType``
numbers (5120 int8 .. 5126 float32, little-endian), read from a bufferView at ``byteOffset`` with
the view's ``byteStride`` (0 or absent: tightly packed). ``normalized`` integers map onto [0, 1]
(unsigned) or [-1, 1] (signed: c / (2^(n-1) - 1), clamped at -1; spec section 3.11).

:func:`layout` checks everything against the declared sizes BEFORE any data is read or allocated:
an accessor that claims more bytes than its bufferView holds, or a view that overruns its buffer,
is one line naming it (``model.gltf: accessors[3]: ...``). Sparse accessors are refused.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .container import Gltf

#: componentType -> little-endian numpy dtype.
COMPONENTS = {5120: "<i1", 5121: "<u1", 5122: "<i2", 5123: "<u2", 5125: "<u4", 5126: "<f4"}
#: accessor type -> components per element (matrices are not vertex data mcpt reads).
WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}
#: Divisors of normalized integers (signed ones clamp at -1).
NORMALIZE = {5120: 127.0, 5121: 255.0, 5122: 32767.0, 5123: 65535.0}


@dataclass(frozen=True)
class Layout:
    """Where an accessor's elements lie: buffer, first byte, stride, shape and component type."""

    buffer: int
    start: int
    stride: int
    count: int
    width: int
    component: int
    normalized: bool

    @property
    def dtype(self) -> np.dtype:
        return np.dtype(COMPONENTS[self.component])


def _int(g: Gltf, obj: dict, key: str, where: str, default=None, low: int = 0) -> int:
    value = obj.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise g.error(where, f"{key} {value!r} is not an integer >= {low}")
    return value


def layout(g: Gltf, index: int, where: str = "") -> Layout:
    """The checked layout of accessor ``index`` (``where``: the element that refers to it)."""
    acc = g.get("accessors", index, where)
    at = f"accessors[{index}]"
    if "sparse" in acc:
        raise g.error(at, "sparse accessors are not supported by mcpt")
    component = acc.get("componentType")
    if component not in COMPONENTS:
        raise g.error(at, f"componentType {component!r} is not one of {', '.join(map(str, COMPONENTS))}")
    width = WIDTHS.get(acc.get("type"))
    if width is None:
        raise g.error(at, f"type {acc.get('type')!r}: mcpt reads {', '.join(WIDTHS)} accessors")
    count = _int(g, acc, "count", at, low=1)
    offset = _int(g, acc, "byteOffset", at, default=0)
    if "bufferView" not in acc:
        raise g.error(at, "no bufferView (all-zero accessors are not supported by mcpt)")
    vi = acc["bufferView"]
    view = g.get("bufferViews", vi, at)
    vat = f"bufferViews[{vi}]"
    size = np.dtype(COMPONENTS[component]).itemsize
    elem = size * width
    stride = _int(g, view, "byteStride", vat, default=0) or elem
    if stride < elem:
        raise g.error(vat, f"byteStride {stride} is shorter than the {elem}-byte elements of {at}")
    need = offset + stride * (count - 1) + elem
    view_len = _int(g, view, "byteLength", vat, low=1)
    if need > view_len:
        raise g.error(at, f"{count} elements of {elem} bytes (stride {stride}) from byteOffset {offset} "
                          f"need {need} bytes, but {vat} has byteLength {view_len}")
    bi = view.get("buffer")
    view_start = _int(g, view, "byteOffset", vat, default=0)
    buf_len = g.buffer_length(bi, vat)
    if view_start + view_len > buf_len:
        raise g.error(vat, f"bytes {view_start}..{view_start + view_len} overrun buffers[{bi}] "
                           f"(byteLength {buf_len})")
    return Layout(bi, view_start + offset, stride, count, width, component, bool(acc.get("normalized", False)))


def read(g: Gltf, index: int, where: str = "") -> np.ndarray:
    """Accessor ``index`` as a (count, width) array: float64 for float and normalized data, the
    file's integer type otherwise."""
    lay = layout(g, index, where)
    data = g.buffer(lay.buffer)
    raw = np.ndarray((lay.count, lay.width), dtype=lay.dtype, buffer=data, offset=lay.start,
                     strides=(lay.stride, lay.dtype.itemsize))
    if lay.component == 5126:
        return raw.astype(np.float64)
    if lay.normalized:
        return np.maximum(raw.astype(np.float64) / NORMALIZE[lay.component], -1.0)
    return np.array(raw)

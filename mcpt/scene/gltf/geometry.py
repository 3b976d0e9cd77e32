"""glTF mesh primitives as vertex arrays (glTF 2.0 spec, section 3.7.2).

Primitives are numbered in file order across meshes (``meshes[0]``'s, then ``meshes[1]``'s, ...):
that number is the ``shape_index`` of a scene mesh entry that places one (mcpt/shapes/
gltf_source.py reads it). Only ``mode`` 4 (TRIANGLES, the default) is read; points, lines, strips
and fans are refused naming the primitive. ``POSITION`` is required; ``NORMAL`` and ``TEXCOORD_0``
are read when present (v flipped: glTF's uv (0, 0) is the image's top-left, mcpt's v points up);
indices, when absent, are 0, 1, 2, ... . :func:`check` validates a primitive from the declared
sizes alone (no data read), so a scene is refused before anything is allocated.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import accessors
from .container import Gltf, obj

MODE_NAMES = {0: "POINTS", 1: "LINES", 2: "LINE_LOOP", 3: "LINE_STRIP", 4: "TRIANGLES",
              5: "TRIANGLE_STRIP", 6: "TRIANGLE_FAN"}


@dataclass
class Primitive:
    """A primitive's arrays: (V, 3) float64 positions, (3F,) int64 indices, optional (V, 3)
    normals and (V, 2) uvs (v up)."""

    label: str
    positions: np.ndarray
    indices: np.ndarray
    normals: np.ndarray | None
    uvs: np.ndarray | None


def primitives(g: Gltf) -> list[tuple[int, int, dict]]:
    """(mesh index, primitive index, primitive) of every primitive, in file order."""
    if "primitives" in g.memo:
        return g.memo["primitives"]
    out = []
    for mi in range(len(g.items("meshes"))):
        prims = g.get("meshes", mi).get("primitives")
        if not isinstance(prims, list) or not prims:
            raise g.error(f"meshes[{mi}]", "primitives must be a non-empty array")
        for pi, prim in enumerate(prims):
            if not isinstance(prim, dict):
                raise g.error(f"meshes[{mi}].primitives[{pi}]", "expected an object")
            out.append((mi, pi, prim))
    g.memo["primitives"] = out
    g.memo["first"] = [0] * len(g.items("meshes"))
    for number, (mi, _, _) in reversed(list(enumerate(out))):
        g.memo["first"][mi] = number
    return out


def of_mesh(g: Gltf, mesh: int) -> range:
    """The primitive numbers of ``meshes[mesh]``."""
    primitives(g)
    first = g.memo["first"][mesh]
    return range(first, first + len(g.get("meshes", mesh)["primitives"]))


def check(g: Gltf, mi: int, pi: int, prim: dict) -> int:
    """Validate a primitive's mode and accessors (sizes only); returns its triangle count."""
    where = f"meshes[{mi}].primitives[{pi}]"
    mode = prim.get("mode", 4)
    if mode != 4:
        raise g.error(where, f"mode {mode!r} ({MODE_NAMES.get(mode, 'unknown')}): mcpt renders "
                             "triangles only (mode 4)")
    if "KHR_draco_mesh_compression" in obj(prim.get("extensions")):
        raise g.error(where, "KHR_draco_mesh_compression is not supported by mcpt")
    attrs = prim.get("attributes")
    if not isinstance(attrs, dict) or "POSITION" not in attrs:
        raise g.error(where, "no POSITION attribute")
    pos = accessors.layout(g, attrs["POSITION"], f"{where}.attributes.POSITION")
    if pos.width != 3:
        raise g.error(f"accessors[{attrs['POSITION']}]", "POSITION must be VEC3")
    for key, width in (("NORMAL", 3), ("TEXCOORD_0", 2)):
        if key in attrs:
            lay = accessors.layout(g, attrs[key], f"{where}.attributes.{key}")
            if lay.width != width or lay.count != pos.count:
                raise g.error(f"accessors[{attrs[key]}]", f"{key}: {lay.count} VEC{lay.width} elements, expected "
                                                          f"{pos.count} VEC{width} (one per POSITION)")
    if "indices" not in prim:
        n = pos.count
    else:
        lay = accessors.layout(g, prim["indices"], f"{where}.indices")
        if lay.width != 1 or lay.component not in (5121, 5123, 5125):
            raise g.error(f"accessors[{prim['indices']}]", "indices must be SCALAR unsigned integers")
        n = lay.count
    if n % 3:
        raise g.error(where, f"{n} indices: not a multiple of 3 (mode 4 is a triangle list)")
    return n // 3


def read(g: Gltf, number: int) -> Primitive:
    """The arrays of primitive ``number`` (file order across meshes)."""
    prims = primitives(g)
    if not 0 <= number < len(prims):
        raise g.error("meshes", f"primitive {number} does not exist ({len(prims)} primitives)")
    mi, pi, prim = prims[number]
    check(g, mi, pi, prim)
    where = f"meshes[{mi}].primitives[{pi}]"
    attrs = prim["attributes"]
    positions = accessors.read(g, attrs["POSITION"])
    if "indices" in prim:
        indices = accessors.read(g, prim["indices"]).reshape(-1).astype(np.int64)
        bad = np.flatnonzero(indices >= len(positions))
        if bad.size:
            raise g.error(f"{where}.indices", f"accessors[{prim['indices']}]: index {int(indices[bad[0]])} "
                                              f"at {int(bad[0])} is out of range ({len(positions)} vertices)")
    else:
        indices = np.arange(len(positions), dtype=np.int64)
    normals = accessors.read(g, attrs["NORMAL"]) if "NORMAL" in attrs else None
    uvs = None
    if "TEXCOORD_0" in attrs:
        uvs = accessors.read(g, attrs["TEXCOORD_0"]).astype(np.float64)
        uvs[:, 1] = 1.0 - uvs[:, 1]
    name = g.get("meshes", mi).get("name")
    label = where + (f" {name!r}" if isinstance(name, str) else "")
    return Primitive(label, positions, indices, normals, uvs)

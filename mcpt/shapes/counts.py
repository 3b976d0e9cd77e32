"""How many triangles a scene mesh entry's geometry holds, read from headers or a streaming scan,
never from the geometry itself (issue #24: mcpt/gpu/scene_size.py refuses an absurd scene before
anything is tessellated or read).

    analytic shape     primitives.triangle_count (exact; tested against the tessellation)
    .serialized        the shape's header (a few hundred bytes decompressed)
    .gltf / .glb       the accessor counts (mcpt/scene/gltf: the JSON, not the buffers)
    .obj               a scan of the face lines, 16 MiB at a time: corners - 2 per face
    .ply / .off        the header's face count (a polygon of k corners is k - 2 triangles: at least that)
    .stl               binary: the header's count; ASCII: the ``endfacet`` lines
    anything else      unknown (0): Assimp reads it, and the upload's own checks still hold

A count is kept per file (path, size, modification time) for the process: a frame sequence or a
scene naming one mesh a thousand times scans it once. A file that cannot be counted counts 0:
its reader reports what is wrong with it, in its own words.
"""

from __future__ import annotations

import logging
import struct
from pathlib import Path

import numpy as np

from . import primitives

log = logging.getLogger("mcpt")

#: Bytes of an OBJ file scanned at a time (bounds the scan's memory whatever the file's size).
CHUNK = 1 << 24
_known: dict[tuple, int] = {}


def entry_source(spec) -> tuple:
    """What an entry's triangles come from, as a key: ``("shape", kind)`` or ``(path, index)``."""
    if spec.shape is not None:
        return ("shape", spec.shape)
    return (str(spec.file), spec.shape_index)


def source_name(source: tuple) -> str:
    """A source key as a message names it: ``sphere``, ``bunny.obj``, ``scene.glb[3]``."""
    if source[0] == "shape":
        return source[1]
    name = Path(source[0]).name
    return name if source[1] is None else f"{name}[{source[1]}]"


def triangles(source: tuple) -> int:
    """Triangles of a source key (:func:`entry_source`); 0 where unknown."""
    if source[0] == "shape":
        return primitives.triangle_count(source[1])
    path, index = Path(source[0]), source[1]
    try:
        st = path.stat()
        key = (str(path), index, st.st_size, st.st_mtime_ns)
        if key not in _known:
            _known[key] = _file_triangles(path, index)
        return _known[key]
    except Exception as exc:  # noqa: BLE001 -- the reader says what is wrong, in its own words
        log.debug("%s: triangles not counted (%s: %s)", path, type(exc).__name__, exc)
        return 0


def _file_triangles(path: Path, index: int | None) -> int:
    suffix = path.suffix.lower()
    if suffix == ".serialized":
        from .serialized import triangle_count

        return triangle_count(path, index or 0)
    if suffix in (".gltf", ".glb"):
        return gltf_triangles(path, index)
    if suffix == ".obj":
        return obj_triangles(path)
    if suffix == ".ply":
        return ply_triangles(path)
    if suffix == ".off":
        return off_triangles(path)
    if suffix == ".stl":
        return stl_triangles(path)
    return 0


def obj_triangles(path: Path) -> int:
    """Triangles of an OBJ's faces: corners - 2 per face statement (Assimp fans polygons)."""
    total, tail = 0, b""
    with open(path, "rb") as fh:
        while True:
            chunk = fh.read(CHUNK)
            data = tail + chunk
            cut = len(data) if not chunk else data.rfind(b"\n") + 1
            total += _face_triangles(data[:cut])
            tail = data[cut:]
            if not chunk:
                return total


def _face_triangles(block: bytes) -> int:
    """Sum of (corners - 2) over the face lines (``f`` then a blank) of ``block`` (whole lines),
    in numpy: a word starts where a blank byte is followed by a non-blank one."""
    a = np.frombuffer(block, np.uint8)
    if a.size < 2:
        return 0
    starts = np.concatenate([[0], np.flatnonzero(a[:-1] == 10) + 1])
    after = a[np.minimum(starts + 1, a.size - 1)]
    face = (a[starts] == ord("f")) & ((after == ord(" ")) | (after == ord("\t")))
    if not face.any():
        return 0
    word = a > 32
    first = np.empty_like(word)
    first[0] = word[0]
    np.greater(word[1:], word[:-1], out=first[1:])
    words = np.add.reduceat(first, starts, dtype=np.int64)[face]  # "f" and the corners
    return max(int(words.sum()) - 3 * words.size, 0)


def _header_lines(path: Path, limit: int = 1 << 16) -> list[bytes]:
    with open(path, "rb") as fh:
        head = fh.read(limit)
    return head.split(b"end_header")[0].splitlines()


def ply_triangles(path: Path) -> int:
    """The header's ``element face N`` (at least N triangles), read by the PLY reader's own header
    parser (mcpt/shapes/ply.py) from the file's first 64 KiB."""
    from .ply import parse_header

    with open(path, "rb") as fh:
        header = parse_header(path, fh.read(1 << 16))
    return next((e.count for e in header.elements if e.name == "face"), 0)


def off_triangles(path: Path) -> int:
    """The face count of an OFF header (``OFF`` then ``vertices faces edges``)."""
    numbers = []
    for line in _header_lines(path, 4096):
        words = line.split(b"#")[0].split()
        if words and words[0].endswith(b"OFF"):
            words = words[1:]
        numbers += words
        if len(numbers) >= 2:
            return int(numbers[1])
    return 0


def stl_triangles(path: Path) -> int:
    """Binary STL: the count after the 80-byte header (when the size agrees); ASCII: ``endfacet``s."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(84)
        if len(head) == 84 and 84 + 50 * struct.unpack("<I", head[80:])[0] == size:
            return struct.unpack("<I", head[80:])[0]
        fh.seek(0)
        total, tail = 0, b""
        while chunk := fh.read(CHUNK):
            data = tail + chunk  # the 7-byte tail holds no whole "endfacet": none is counted twice
            total += data.count(b"endfacet")
            tail = data[-7:]
        return total


def gltf_triangles(path: Path, index: int | None) -> int:
    """Primitive ``index`` of a glTF file, or (None) every primitive its default scene places,
    instances counted: from the accessors' counts (mcpt/scene/gltf/geometry.py check)."""
    from ..scene.gltf import geometry, nodes, open_gltf

    g = open_gltf(path)
    prims = geometry.primitives(g)
    if index is not None:
        return geometry.check(g, *prims[index])
    total = 0
    for ni, world in nodes.instances(g):
        node = g.get("nodes", ni)
        if "mesh" in node and np.linalg.det(world[:3, :3]) != 0.0:
            total += sum(geometry.check(g, *prims[k]) for k in geometry.of_mesh(g, node["mesh"]))
    return total

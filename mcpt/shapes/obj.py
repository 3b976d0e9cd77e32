"""OBJ specifics Assimp does not give: line numbers of bad vertices and faces, float64 coordinates
far from the origin, and which MTL keywords a material really declares (Assimp fills defaults)."""

from __future__ import annotations

import logging
import math
import re
from pathlib import Path

import numpy as np

log = logging.getLogger("mcpt")


_OBJ_VERTEX = re.compile(rb"^[ \t]*v[ \t]+(\S+)[ \t]+(\S+)[ \t]+(\S+)", re.MULTILINE)
_OBJ_FACE = re.compile(rb"^[ \t]*f[ \t]+([^\r\n#]*)", re.MULTILINE)
FLOAT32_MAX = float(np.finfo(np.float32).max)

#: Assimp parses OBJ coordinates as float32. When a mesh's coordinates are more than this many
#: times its own size, the rounding is visible (relative to the mesh), so the file's own float64
#: values are read back (see _restore_obj_precision).
OBJ_FLOAT64_RATIO = 64.0


def _line_of(data: bytes, offset: int) -> int:
    return data.count(b"\n", 0, offset) + 1


def bad_vertex(path: Path) -> str | None:
    """A message naming ``file:line`` for the first vertex that is NaN, infinite or beyond
    float32 (Assimp would read the latter as inf). A quick byte search skips clean files."""
    try:
        data = path.read_bytes()
    except OSError:
        return None  # Assimp reports unreadable files
    low = (b"nan", b"NaN", b"NAN", b"inf", b"Inf", b"INF")
    if not any(t in data for t in low) and re.search(rb"[eE]\+?(3[89]|[4-9]\d|\d{3})", data) is None:
        return None
    for k, m in enumerate(_OBJ_VERTEX.finditer(data)):
        try:
            xyz = [float(t) for t in m.groups()]
        except ValueError:
            continue  # Assimp decides what to do with a malformed number
        if not all(math.isfinite(x) and abs(x) <= FLOAT32_MAX for x in xyz):
            text = data[m.start():data.find(b"\n", m.start())].decode("utf-8", "replace").strip()
            return (f"{path}:{_line_of(data, m.start())}: vertex {k + 1} is not finite "
                    f"(NaN, inf or beyond float32): {text!r}")
    return None


def bad_face(path: Path) -> str | None:
    """'file:line: ...' for the first face whose vertex index is out of range, or None."""
    data = path.read_bytes()
    count = 0
    ends = [m.start() for m in _OBJ_VERTEX.finditer(data)]
    total = len(ends)
    for m in _OBJ_FACE.finditer(data):
        before = int(np.searchsorted(ends, m.start()))  # vertices defined above this face
        for tok in m.group(1).split():
            try:
                i = int(tok.split(b"/")[0])
            except ValueError:
                return f"{path}:{_line_of(data, m.start())}: face index {tok.decode(errors='replace')!r} is not an integer"
            ok = 1 <= i <= total if i > 0 else (i < 0 and -i <= before)
            if not ok:
                return (f"{path}:{_line_of(data, m.start())}: face vertex index {i} out of range "
                        f"(the file has {total} vertices, indices are 1-based)")
        count += 1
    return None


def restore_precision(path: Path, parts: list) -> None:
    """Replace Assimp's float32 coordinates by the file's float64 ones where it matters.

    A Cornell box written at x = 1e5 loses everything below 1/128 in float32, before mcpt's
    camera-relative float64 rebasing could keep it (issue #6). Every Assimp vertex is the float32
    rounding of some file vertex; where that file vertex is unique the float64 value is restored.
    If two different file vertices round to the same float32 vertex, Assimp has already merged
    them: precision is lost and a warning says so (a YAML ``transform`` keeps far-away meshes
    exact)."""
    allv = np.concatenate([p.vertices for p in parts])
    if allv.size == 0 or not np.isfinite(allv).all():
        return
    extent = float(np.max(allv.max(axis=0) - allv.min(axis=0)))
    if float(np.abs(allv).max()) <= OBJ_FLOAT64_RATIO * max(extent, 1e-300):
        return
    data = path.read_bytes()
    try:
        exact = np.array([[float(t) for t in m.groups()] for m in _OBJ_VERTEX.finditer(data)])
    except ValueError:
        return
    if exact.size == 0:
        return
    keys = np.ascontiguousarray(exact.astype(np.float32)).view(np.dtype((np.void, 12))).ravel()
    order = np.argsort(keys, kind="stable")
    sk, se = keys[order], exact[order]
    clash = (sk[1:] == sk[:-1]) & np.any(se[1:] != se[:-1], axis=1)
    if clash.any():
        log.warning("%s: %d vertices differ only below float32 precision at coordinates up to %.3g:"
                    " they were merged; place the mesh with a YAML transform instead of far-away"
                    " coordinates", path, int(clash.sum()), float(np.abs(exact).max()))
        return
    for p in parts:
        q = np.ascontiguousarray(p.vertices.astype(np.float32)).view(np.dtype((np.void, 12))).ravel()
        pos = np.searchsorted(sk, q)
        pos = np.minimum(pos, len(sk) - 1)
        found = sk[pos] == q
        p.vertices = np.where(found[:, None], se[pos], p.vertices)



_MTLLIB = re.compile(rb"^[ \t]*mtllib[ \t]+(.+?)[ \t]*\r?$", re.MULTILINE)


def mtl_declarations(obj_path: Path) -> dict[str, set[str]]:
    """Map material name -> lower-cased MTL keywords it declares, for the OBJ's mtllib files.

    A regex over the raw bytes finds `mtllib` lines without splitting a 40 MB OBJ into lines.
    Missing or unreadable MTL files are simply absent (Assimp then uses its default material).
    """
    declared: dict[str, set[str]] = {}
    try:
        data = obj_path.read_bytes()
    except OSError:
        return declared
    for match in _MTLLIB.finditer(data):
        spec = match.group(1).decode("utf-8", "replace")
        # The spec allows several files per line; a single name with spaces is also common.
        candidates = [spec] if (obj_path.parent / spec).is_file() else spec.split()
        for name in candidates:
            mtl = obj_path.parent / name
            try:
                text = mtl.read_text(encoding="utf-8", errors="replace")
            except OSError:
                continue
            current: set[str] | None = None
            for line in text.splitlines():
                fields = line.split(None, 1)
                if not fields:
                    continue
                key = fields[0].lower()
                if key == "newmtl":
                    current = declared.setdefault(fields[1].strip() if len(fields) > 1 else "", set())
                elif current is not None:
                    current.add(key)
    return declared

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


def _mtl_files(obj_path: Path) -> list[Path]:
    """The MTL files an OBJ names in its ``mtllib`` lines (existing or not), in order.

    A regex over the raw bytes finds `mtllib` lines without splitting a 40 MB OBJ into lines."""
    try:
        data = obj_path.read_bytes()
    except OSError:
        return []
    files = []
    for match in _MTLLIB.finditer(data):
        spec = match.group(1).decode("utf-8", "replace")
        # The spec allows several files per line; a single name with spaces is also common.
        candidates = [spec] if (obj_path.parent / spec).is_file() else spec.split()
        files += [obj_path.parent / name for name in candidates]
    return files


def _mtl_statements(obj_path: Path):
    """(mtl file, material name, lower-cased keyword, rest of the line) for every statement inside
    a ``newmtl`` block of the OBJ's MTL files. Missing or unreadable MTL files are skipped
    (Assimp then uses its default material)."""
    for mtl in _mtl_files(obj_path):
        try:
            text = mtl.read_text(encoding="utf-8", errors="replace")
        except OSError:
            continue
        current: str | None = None
        for line in text.splitlines():
            fields = line.split(None, 1)
            if not fields or fields[0].startswith("#"):
                continue
            key = fields[0].lower()
            rest = fields[1].strip() if len(fields) > 1 else ""
            if key == "newmtl":
                current = rest
            elif current is not None:
                yield mtl, current, key, rest


def mtl_declarations(obj_path: Path) -> dict[str, set[str]]:
    """Map material name -> lower-cased MTL keywords it declares, for the OBJ's mtllib files."""
    declared: dict[str, set[str]] = {}
    for _, name, key, _ in _mtl_statements(obj_path):
        declared.setdefault(name, set()).add(key)
    return declared


#: Options of MTL texture statements (``map_Kd -s 1 1 1 file.png``) and how many values each takes
#: (Wavefront MTL specification); ``-o``, ``-s``, ``-t`` take 1 to 3 numbers.
_MAP_OPTIONS = {"-blendu": 1, "-blendv": 1, "-bm": 1, "-boost": 1, "-cc": 1, "-clamp": 1,
                "-imfchan": 1, "-mm": 2, "-o": 3, "-s": 3, "-t": 3, "-texres": 1, "-type": 1}


def _map_file(rest: str) -> str:
    """The file name of a texture statement, its options skipped (a name may contain spaces)."""
    tokens = rest.split()
    i = 0
    while i < len(tokens) and tokens[i].lower() in _MAP_OPTIONS:
        n = _MAP_OPTIONS[tokens[i].lower()]
        i += 1
        if n == 3:  # up to three numbers
            while n and i < len(tokens) - 1 and _is_number(tokens[i]):
                i, n = i + 1, n - 1
        else:
            i += n
    return " ".join(tokens[i:])


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


#: MTL texture statements mcpt reads: the diffuse colour and the emitted radiance.
MTL_MAPS = ("map_kd", "map_ke")


def mtl_textures(obj_path: Path) -> dict[str, dict[str, tuple[Path, Path]]]:
    """Map material name -> {"map_kd" / "map_ke": (mtl file, texture path)}; texture paths are
    relative to the MTL file's folder (as the format says), backslashes read as slashes."""
    maps: dict[str, dict[str, tuple[Path, Path]]] = {}
    for mtl, name, key, rest in _mtl_statements(obj_path):
        if key in MTL_MAPS:
            file = _map_file(rest).replace("\\", "/")
            if file:
                maps.setdefault(name, {})[key] = (mtl, (mtl.parent / file))
    return maps

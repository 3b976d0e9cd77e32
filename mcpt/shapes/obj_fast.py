"""A numpy reader for the common OBJ subset that gives what Assimp gives, bit for bit (issue #23).

Assimp's import of a 10^6-triangle OBJ costs seconds: its parse, then JoinIdenticalVertices. This
reader covers files made only of ``v`` (three numbers), ``vt`` (two or three), ``vn``, ``f``
(triangles and quads, every face with the same ``v``, ``v/vt``, ``v//vn`` or ``v/vt/vn`` form,
positive indices), ``s`` and ``#`` lines and blank lines: the scanned, generated and exported
meshes mcpt meets. Anything else (``o``/``g``/``usemtl``/``mtllib``, larger polygons, negative
indices, NaN, commas, line continuations, ...) returns None and Assimp reads the file as before.

What Assimp 5.4 makes of such a file (code/AssetLib/Obj, code/PostProcessing/JoinVerticesProcess.cpp):
one mesh ``defaultobject`` with the invented material ``DefaultMaterial``; its vertices are the
face corners, joined where position, normal and UV agree within 1e-5 (the first corner's values
kept), numbered in order of first use (obj_join.py, which sends a file whose join it cannot
predict to Assimp). Numbers are parsed as Assimp parses them (obj_numbers.py).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..parallel import ordered
from .obj_join import joined
from .obj_numbers import PAD, SKIP, VN, VT, F, Unsupported, V, assimp_floats, digit_values, token_bounds
from .raw_mesh import RawMesh

#: Separators Assimp's OBJ parser skips, and ``/`` between a corner's indices: all become spaces.
_TO_SPACE = bytes.maketrans(b"\t\r\n/", b"    ")
_NUMBER_BYTES = b"0123456789.-+eE "
#: Face lines of the ``v`` form read in one call (_v_faces): f -> 0, tab and line breaks -> space.
_V_FACES = bytes.maketrans(b"f\t\r\n", b"0   ")
#: Bytes parsed at a time (whole lines), so that every temporary stays small and in cache:
#: the 40 MB sphere of issue #23 reads in 1.0-1.1 CPU s with blocks of 256 KB to 2 MB, 1.1-1.25
#: with 4 MB, 1.45-1.6 in one piece.
BLOCK_BYTES = 1 << 20


def read_obj_fast(path: Path, data: bytes, *, need_normals: bool = False) -> RawMesh | None:
    """The OBJ ``data`` (the bytes of ``path``) as Assimp's import gives it, or None when the file
    is outside the subset this module reads exactly (module docstring)."""
    try:
        return _read(Path(path), data, need_normals)
    except Unsupported:
        return None


def _read(path: Path, data: bytes, need_normals: bool) -> RawMesh:
    """read_obj_fast's work, a block of whole lines at a time; raises Unsupported where the file
    leaves the subset."""
    if not data or b"\\" in data or (b"\r" in data and data.count(b"\r") != data.count(b"\r\n")):
        raise Unsupported("empty, line continuations or lone carriage returns")
    fields = _first_face_form(data)
    bounds, a = [], 0
    while a < len(data):
        z = data.find(b"\n", a + BLOCK_BYTES)
        z = len(data) if z < 0 else z + 1
        bounds.append((a, z))
        a = z
    scan = _Scan(fields)
    # Blocks need nothing from each other: parsed on every core, gathered in file order
    # (mcpt/parallel.py), so the result is the sequential one.
    for block in ordered(lambda b: _block(data[b[0]:b[1]], fields), bounds):
        scan.add(block)
    if fields is None:
        raise Unsupported("no faces")
    if len(scan.uv_dims) > 1:
        raise Unsupported("texture coordinate dimension")
    uv_dim = max(scan.uv_dims, default=0)
    tables = {k: np.concatenate(scan.floats[k]).reshape(-1, 3 if k != VT else max(uv_dim, 1))
              for k in (V, VT, VN)}
    if uv_dim == 2:  # Assimp stores 2-D texture coordinates with z = 0
        tables[VT] = np.column_stack([tables[VT], np.zeros(len(tables[VT]), np.float32)])
    corners = np.concatenate(scan.faces).reshape(-1, len(fields))
    for j, f in enumerate(fields):
        if (corners[:, j] < 0).any() or (corners[:, j] >= len(tables[f])).any():
            raise Unsupported("face index out of range")  # Assimp reports it (obj.bad_face)
    sizes = np.concatenate(scan.sizes)
    tri = None if (sizes == 3).all() else _triangulated(corners[:, 0], sizes, tables[V])
    return joined(path, corners, fields, tables, need_normals, tri)


def _triangulated(vertex: np.ndarray, sizes: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """(T, 3) corner numbers of the triangles Assimp's TriangulateProcess makes of triangles and
    quads (``vertex``: each corner's v index, ``sizes``: each face's corner count): a quad is
    fanned from its concave corner, the first whose two angles to the opposite diagonal add up
    to more than pi, else from corner 0. Assimp decides in float32 (normalised edges, acosf):
    a quad whose decision lies within 1e-4 rad of pi, or with a zero or folded edge, is left to
    Assimp. (Triangulation runs before JoinIdenticalVertices: corner numbers are unique, so the
    ngon encoding's swaps never apply.)"""
    first = np.cumsum(sizes) - sizes
    n_tri = sizes - 2
    at = np.cumsum(n_tri) - n_tri
    out = np.empty((int(n_tri.sum()), 3), np.int64)
    t = sizes == 3
    out[at[t]] = first[t, None] + np.arange(3)
    q0 = first[sizes == 4]
    p = positions[vertex[q0[:, None] + np.arange(4)]].astype(np.float64)  # (Q, 4, 3)
    angle = np.empty((len(q0), 4))
    for i in range(4):
        v = p[:, i]
        edges = [p[:, (i + 3) % 4] - v, p[:, (i + 2) % 4] - v, p[:, (i + 1) % 4] - v]
        length = [np.linalg.norm(e, axis=1) for e in edges]
        if any((x <= 0).any() for x in length):
            raise Unsupported("a quad with a zero edge")
        left, diag, right = (e / x[:, None] for e, x in zip(edges, length))
        dots = np.stack([np.einsum("ij,ij->i", left, diag), np.einsum("ij,ij->i", right, diag)])
        if (np.abs(dots) > 1 - 1e-6).any():
            raise Unsupported("a folded quad")  # acosf of a rounded dot may be NaN in Assimp
        angle[:, i] = np.arccos(dots[0]) + np.arccos(dots[1])
    concave = angle > np.pi
    start = np.where(concave.any(axis=1), np.argmax(concave, axis=1), 0)
    decided = np.arange(4) <= np.where(concave.any(axis=1), start, 3)[:, None]
    if (decided & (np.abs(angle - np.pi) < 1e-4)).any():
        raise Unsupported("a quad Assimp may fan either way")
    c = q0[:, None] + (start[:, None] + np.arange(4)) % 4
    qa = at[sizes == 4]
    out[qa] = c[:, [0, 1, 2]]
    out[qa + 1] = c[:, [0, 2, 3]]
    return out


class _Scan:
    """What the blocks of a file give, in file order: the numbers of each table, the corners'
    indices, the face corners' form, the vt dimensions seen."""

    def __init__(self, fields: tuple[int, ...] | None) -> None:
        self.fields = fields
        self.uv_dims: set[int] = set()
        self.floats: dict[int, list[np.ndarray]] = {V: [], VT: [], VN: []}
        self.faces: list[np.ndarray] = []
        self.sizes: list[np.ndarray] = []  # corners of every face (3 or 4)

    def add(self, block: dict) -> None:
        """Append the next block's :func:`_block` result."""
        self.uv_dims |= block["uv_dims"]
        self.sizes.append(block["sizes"])
        for k in (V, VT, VN):
            if k in block:
                self.floats[k].append(block[k])
        if block["faces"] is not None:
            self.faces.append(block["faces"])


def _first_face_form(data: bytes) -> tuple[int, ...] | None:
    """The face form (:func:`_face_form`) of the file's first ``f`` line, None without one, known
    before any block is parsed so that blocks need nothing from each other. A line outside the
    subset before it would make the file Unsupported in its own block anyway."""
    at = _first_statement(data, b"f", len(data))
    if at < 0:
        return None
    end = data.find(b"\n", at)
    # A vt line before the first face decides how "a/b" corners read (getFace in Assimp).
    vt_seen = _first_statement(data, b"vt", at) >= 0
    return _face_form(data[at:len(data) if end < 0 else end], vt_seen)


def _first_statement(data: bytes, keyword: bytes, stop: int) -> int:
    """Where the first line ``keyword`` + space or tab starts before ``stop``, or -1. Found by
    the keyword's last letter (a one-byte find is a memchr, 10x faster than finding "\\nf ":
    every line starts after a newline); number lines hold neither f nor t."""
    last, n = keyword[-1:], len(keyword)
    q = data.find(last, n - 1, stop)
    while q >= 0:
        a = q - n + 1
        if data[a:q + 1] == keyword and (a == 0 or data[a - 1] == 10) and data[q + 1:q + 2] in (b" ", b"\t"):
            return a
        q = data.find(last, q + 1, stop)
    return -1


def _block(data: bytes, fields: tuple[int, ...] | None) -> dict:
    """Parse ``data``, whole lines of the file: its vt dimensions, face sizes, numbers of each
    table and corners' indices (module docstring)."""
    raw = np.frombuffer(data, np.uint8)
    starts, ends, kind = _lines(raw)
    if fields == (V,) and (kind == F).all():
        fast = _v_faces(data, len(starts))
        if fast is not None:
            return fast
    text = _numbers_only(data, starts, ends, kind)
    tok_a, tok_z = token_bounds(text)
    counts = np.diff(np.append(np.searchsorted(tok_a, starts), len(tok_a)))
    out: dict = {"uv_dims": _check_counts(counts, kind, len(fields or ())),
                 "sizes": counts[kind == F] // max(len(fields or ()), 1), "faces": None}
    tok_kind = np.repeat(kind, counts)
    is_float = tok_kind != F
    if is_float.any():
        fa, fz = tok_a[is_float], tok_z[is_float]
        lead = text[fa]
        if ((lead < 48) & (lead != 43) & (lead != 45)).any():
            # Assimp counts a v/vt number only if it starts with a digit or sign (ObjTools.h
            # IsNumeric): "v .5 1 2" is two numbers to it, and the vertex is dropped.
            raise Unsupported("a number starting with '.'")
        if (raw[np.minimum(fz, len(raw) - 1)] == ord("/")).any():
            raise Unsupported("'/' in a v/vt/vn line")  # one word to Assimp, two numbers here
        values = assimp_floats(text, fa, fz)
        of_kind = tok_kind[is_float]
        for k in (V, VT, VN):
            out[k] = values[of_kind == k]
    if not is_float.all():
        out["faces"] = _face_indices(raw, text, tok_a[~is_float], tok_z[~is_float], fields)
    return out


def _v_faces(data: bytes, n_lines: int) -> dict | None:
    """_block's result for ``data``, ``n_lines`` lines that all start with ``f`` in a file whose
    faces have the ``v`` form, or None where _block's general path must decide (a byte other than
    digits and separators, an index that is 0 or starts with 0, a face of other than 3 or 4
    corners). Every line's ``f`` becomes a 0, which no index can be, so numpy's C integer parser
    reads the whole block in one call and the zeros mark where lines start (issue #23: 30 ns an
    index against ~150 for token bounds and digit columns; face lines are 60% of a big mesh)."""
    if data.count(b"f") != n_lines:
        return None  # an f inside a line would read as a digit 0
    text = data.translate(_V_FACES)
    if text.translate(None, b"0123456789 "):
        return None  # '/', signs, dots, comments: not this form
    # Each line's 0 starts the block or follows a line break (a space now); any other " 0" is an
    # index that starts with 0, which Assimp reads its own way (_face_indices).
    if text.count(b" 0") + 1 != n_lines:
        return None
    values = np.fromstring(text, np.int64, sep=" ")
    if len(values) and values.max() >= 10**18:
        return None  # past 18 digits (read as 2^63 - 1 here): the general path refuses them
    if len(values) == 4 * n_lines:
        rows = values.reshape(n_lines, 4)
        if not rows[:, 0].any() and rows[:, 1:].all():  # all triangles: a zero, three indices
            return {"uv_dims": set(), "sizes": np.full(n_lines, 3, np.int64), "faces": (rows[:, 1:] - 1).ravel()}
    line_at = np.flatnonzero(values == 0)
    corners = np.diff(np.append(line_at, len(values))) - 1
    if len(line_at) != n_lines or ((corners != 3) & (corners != 4)).any():
        return None
    return {"uv_dims": set(), "sizes": corners, "faces": values[values != 0] - 1}


def _lines(raw: np.ndarray):
    """(starts, ends, kind) of every line; raises Unsupported for a line outside the subset."""
    nl = np.flatnonzero(raw == 10)
    starts = np.concatenate([[0], nl + 1])
    ends = np.concatenate([nl, [len(raw)]])
    if starts[-1] == len(raw):
        starts, ends = starts[:-1], ends[:-1]
    last = len(raw) - 1
    c0, c1, c2 = (raw[np.minimum(starts + k, last)] for k in range(3))
    length = ends - starts
    c1 = np.where(length > 1, c1, 10)
    c2 = np.where(length > 2, c2, 10)
    space1, space2 = (c1 == 32) | (c1 == 9), (c2 == 32) | (c2 == 9)
    v = c0 == ord("v")
    kind = np.full(len(starts), -1, np.int8)
    kind[v & space1] = V
    kind[v & (c1 == ord("t")) & space2] = VT
    kind[v & (c1 == ord("n")) & space2] = VN
    kind[(c0 == ord("f")) & space1] = F
    blank = (length == 0) | ((length == 1) & (c0 == 13))
    kind[blank | (c0 == ord("#")) | ((c0 == ord("s")) & space1)] = SKIP
    if (kind < 0).any():
        raise Unsupported("a statement outside v/vt/vn/f/s/#")
    return starts, ends, kind


def _numbers_only(data: bytes, starts, ends, kind) -> np.ndarray:
    """The file's bytes with every separator made a space and statements' keywords, comments and
    ``s`` lines blanked, PAD spaces appended; raises Unsupported if anything but number bytes is
    left. (One translated copy, made writable in place: big temporaries cost page faults.)"""
    buf = bytearray(data.translate(_TO_SPACE))
    buf += b" " * PAD
    text = np.frombuffer(buf, np.uint8)
    text[starts[kind != SKIP]] = 32
    two = starts[(kind == VT) | (kind == VN)]
    text[two + 1] = 32
    skip = (kind == SKIP) & (ends > starts)
    if skip.any():
        a, n = starts[skip], (ends - starts)[skip]
        offsets = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
        text[np.repeat(a, n) + offsets] = 32
    if buf.translate(None, _NUMBER_BYTES):
        raise Unsupported("bytes other than numbers in v/vt/vn/f lines")
    return text


def _face_form(line: bytes, vt_seen: bool) -> tuple[int, ...]:
    """Which tables a corner indexes, from the first face ``line``: (V,), (V, VT), (V, VN)
    or all three (every face is checked against it in _face_indices). ``vt_seen``: a vt line came
    before it."""
    words = line.split()
    if len(words) < 2:
        raise Unsupported("a face without corners")
    corner = words[1].split(b"/")
    form = {(1,): (V,), (1, 1): (V, VT), (1, 0, 1): (V, VN), (1, 1, 1): (V, VT, VN)}
    key = tuple(int(bool(c)) for c in corner)
    if key not in form:
        raise Unsupported("face corner form")
    if key[1:2] == (1,) and not vt_seen:
        # Assimp reads "a/b" as a normal index when no vt line came before the face (getFace).
        raise Unsupported("texture coordinates after the faces")
    return form[key]


def _check_counts(counts, kind, n_fields: int) -> set[int]:
    """Checks that v/vn lines hold 3 numbers, f lines 3 or 4 corners; returns the vt dimensions."""
    for k, n in ((V, 3), (VN, 3), (SKIP, 0)):
        if (counts[kind == k] != n).any():
            raise Unsupported("numbers per line")
    face = counts[kind == F]
    if ((face != 3 * n_fields) & (face != 4 * n_fields)).any():
        raise Unsupported("a face of other than 3 or 4 corners")
    uv = {int(d) for d in np.unique(counts[kind == VT])}
    if not uv <= {2, 3}:
        raise Unsupported("texture coordinate dimension")
    return uv


def _face_indices(raw, text, a, z, fields) -> np.ndarray:
    """(F*3 * len(fields),) zero-based indices of every corner's fields; raises Unsupported where
    a face differs in form from the first one (_read checks the ranges)."""
    k = len(fields)
    after = raw[np.minimum(z, len(raw) - 1)]
    after = np.where(z < len(raw), after, 10).reshape(-1, k)
    slash = ord("/")
    if (after[:, :-1] != slash).any() or (after[:, -1] == slash).any():
        raise Unsupported("face corner form")
    if fields == (V, VN):
        if (raw[np.minimum(z.reshape(-1, k)[:, 0] + 1, len(raw) - 1)] != slash).any():
            raise Unsupported("face corner form")
    if (text[a] == ord("0")).any():
        # Assimp steps over an index by the digit count of its value: "07" is read as 7 twice.
        raise Unsupported("a face index with a leading zero")
    return digit_values(text, a, z) - 1

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
kept), numbered in order of first use. Two *different* values within 1e-5 are joined only when
their hashes meet in a bucket of Assimp's hash map, which cannot be predicted here: such a file
(:func:`_near_pairs`) goes to Assimp. Otherwise the join is an exact one (-0.0 = 0.0), done on
the file's index tables. Numbers are parsed as Assimp parses them (obj_numbers.py).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..parallel import ordered
from .dedup import first_equal
from .obj_numbers import PAD, Unsupported, assimp_floats, digit_values, token_bounds
from .raw_mesh import MeshMaterial, RawMesh, RawPart
from .rows import take_rows

#: Assimp's vertex-join tolerance (JoinVerticesProcess.cpp, ``epsilon``), widened a little so that
#: float32 rounding in Assimp's own test can never join a pair this check lets through.
JOIN_EPSILON = 1.1e-5
#: Shifted grids of the join check (_near_pairs): more than the 3 axes of a table.
_GRIDS = 4
_V, _VT, _VN, _F, _SKIP = range(5)
#: Separators Assimp's OBJ parser skips, and ``/`` between a corner's indices: all become spaces.
_TO_SPACE = bytes.maketrans(b"\t\r\n/", b"    ")
_NUMBER_BYTES = b"0123456789.-+eE "
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
    tables = {k: np.concatenate(scan.floats[k]).reshape(-1, 3 if k != _VT else max(uv_dim, 1))
              for k in (_V, _VT, _VN)}
    if uv_dim == 2:  # Assimp stores 2-D texture coordinates with z = 0
        tables[_VT] = np.column_stack([tables[_VT], np.zeros(len(tables[_VT]), np.float32)])
    corners = np.concatenate(scan.faces).reshape(-1, len(fields))
    for j, f in enumerate(fields):
        if (corners[:, j] < 0).any() or (corners[:, j] >= len(tables[f])).any():
            raise Unsupported("face index out of range")  # Assimp reports it (obj.bad_face)
    sizes = np.concatenate(scan.sizes)
    tri = None if (sizes == 3).all() else _triangulated(corners[:, 0], sizes, tables[_V])
    return _joined(path, corners, fields, tables, need_normals, tri)


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
        self.floats: dict[int, list[np.ndarray]] = {_V: [], _VT: [], _VN: []}
        self.faces: list[np.ndarray] = []
        self.sizes: list[np.ndarray] = []  # corners of every face (3 or 4)

    def add(self, block: dict) -> None:
        """Append the next block's :func:`_block` result."""
        self.uv_dims |= block["uv_dims"]
        self.sizes.append(block["sizes"])
        for k in (_V, _VT, _VN):
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
    text = _numbers_only(data, starts, ends, kind)
    tok_a, tok_z = token_bounds(text)
    counts = np.diff(np.append(np.searchsorted(tok_a, starts), len(tok_a)))
    out: dict = {"uv_dims": _check_counts(counts, kind, len(fields or ())),
                 "sizes": counts[kind == _F] // max(len(fields or ()), 1), "faces": None}
    tok_kind = np.repeat(kind, counts)
    is_float = tok_kind != _F
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
        for k in (_V, _VT, _VN):
            out[k] = values[of_kind == k]
    if not is_float.all():
        out["faces"] = _face_indices(raw, text, tok_a[~is_float], tok_z[~is_float], fields)
    return out


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
    kind[v & space1] = _V
    kind[v & (c1 == ord("t")) & space2] = _VT
    kind[v & (c1 == ord("n")) & space2] = _VN
    kind[(c0 == ord("f")) & space1] = _F
    blank = (length == 0) | ((length == 1) & (c0 == 13))
    kind[blank | (c0 == ord("#")) | ((c0 == ord("s")) & space1)] = _SKIP
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
    text[starts[kind != _SKIP]] = 32
    two = starts[(kind == _VT) | (kind == _VN)]
    text[two + 1] = 32
    skip = (kind == _SKIP) & (ends > starts)
    if skip.any():
        a, n = starts[skip], (ends - starts)[skip]
        offsets = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
        text[np.repeat(a, n) + offsets] = 32
    if buf.translate(None, _NUMBER_BYTES):
        raise Unsupported("bytes other than numbers in v/vt/vn/f lines")
    return text


def _face_form(line: bytes, vt_seen: bool) -> tuple[int, ...]:
    """Which tables a corner indexes, from the first face ``line``: (_V,), (_V, _VT), (_V, _VN)
    or all three (every face is checked against it in _face_indices). ``vt_seen``: a vt line came
    before it."""
    words = line.split()
    if len(words) < 2:
        raise Unsupported("a face without corners")
    corner = words[1].split(b"/")
    form = {(1,): (_V,), (1, 1): (_V, _VT), (1, 0, 1): (_V, _VN), (1, 1, 1): (_V, _VT, _VN)}
    key = tuple(int(bool(c)) for c in corner)
    if key not in form:
        raise Unsupported("face corner form")
    if key[1:2] == (1,) and not vt_seen:
        # Assimp reads "a/b" as a normal index when no vt line came before the face (getFace).
        raise Unsupported("texture coordinates after the faces")
    return form[key]


def _check_counts(counts, kind, n_fields: int) -> set[int]:
    """Checks that v/vn lines hold 3 numbers, f lines 3 or 4 corners; returns the vt dimensions."""
    for k, n in ((_V, 3), (_VN, 3), (_SKIP, 0)):
        if (counts[kind == k] != n).any():
            raise Unsupported("numbers per line")
    face = counts[kind == _F]
    if ((face != 3 * n_fields) & (face != 4 * n_fields)).any():
        raise Unsupported("a face of other than 3 or 4 corners")
    uv = {int(d) for d in np.unique(counts[kind == _VT])}
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
    if fields == (_V, _VN):
        if (raw[np.minimum(z.reshape(-1, k)[:, 0] + 1, len(raw) - 1)] != slash).any():
            raise Unsupported("face corner form")
    if (text[a] == ord("0")).any():
        # Assimp steps over an index by the digit count of its value: "07" is read as 7 twice.
        raise Unsupported("a face index with a leading zero")
    return digit_values(text, a, z) - 1


def _first_equal_rows(table: np.ndarray) -> np.ndarray | None:
    """For every row of a float32 table, the index of the first row equal to it as floats
    (-0.0 equals 0.0: libstdc++ hashes both to 0, so Assimp joins them; _joined keeps the bits
    of the corner that uses the value first, as Assimp does); None when every row is its own
    first (no two rows equal: the usual case). Raises Unsupported for a pair of near rows
    (:func:`_near_pairs`)."""
    canon = table + np.float32(0.0)  # -0.0 + 0.0 = +0.0
    ids = first_equal(np.ascontiguousarray(canon).view(np.uint32))
    if ids is None:
        raise Unsupported("hash collision")  # different rows, one 64-bit hash: let Assimp join
    distinct = ids == np.arange(len(ids))
    if _near_pairs(table if distinct.all() else table[distinct]):
        raise Unsupported("values within Assimp's join tolerance")
    return None if distinct.all() else ids


def _near_pairs(rows: np.ndarray) -> bool:
    """Whether two distinct rows may lie within JOIN_EPSILON of each other (conservative: a
    "may" sends the file to Assimp). Each axis is cut into steps of u = 1.25 JOIN_EPSILON
    (q = floor(value / u)); grid i (i = 0..3) groups 4 steps per cell, shifted by i steps. Two
    values within JOIN_EPSILON < u lie in the same or neighbouring steps, and a step boundary is
    a cell boundary of exactly one grid, so along each of the k <= 3 axes a near pair is split by
    one grid at most: of the 4 grids at least one holds it in one cell (the shifting lemma
    of Chan 1998, "Approximate nearest neighbor queries revisited"; 2^k grids of two shifts
    each, as before, cost twice the sorts: 0.11 s at 5 * 10^5 rows, issue #23). Each grid's
    cells are hashed to one int64 and sorted; a cell holding two rows is decided by their
    distance, one holding more counts as "may"."""
    m, k = rows.shape
    if m < 2:
        return False
    if k >= _GRIDS:
        return True  # not a v, vt or vn table: the grids would not cover every axis
    r = rows.astype(np.float64)
    with np.errstate(over="ignore", invalid="ignore"):
        step = np.floor(r * (1.0 / (1.25 * JOIN_EPSILON)))
    if not np.isfinite(step).all() or np.abs(step).max() > 2.0**60:
        return True
    step = step.astype(np.int64)
    mult = (1, 0x9E3779B1, 0x85EBCA77)[:k]
    cols = [np.ascontiguousarray(step[:, ax]) for ax in range(k)]

    def near_in_grid(shift: int) -> bool:
        # The cell's hash: sum over the axes of ((q + shift) >> 2) * multiplier (cells of 4
        # steps), in place (new temporaries cost page faults).
        key = cols[0] + shift
        key >>= 2
        tmp = np.empty_like(key)
        for ax in range(1, k):
            np.add(cols[ax], shift, out=tmp)
            tmp >>= 2
            tmp *= mult[ax]
            key += tmp
        s = np.sort(key)
        same = s[1:] == s[:-1]
        if not same.any():
            return False
        if (same[1:] & same[:-1]).any():
            return True  # three rows in one cell (or a hash clash): let Assimp decide
        order = np.argsort(key, kind="stable")
        i = np.flatnonzero(key[order][1:] == key[order][:-1])
        diff = r[order[i]] - r[order[i + 1]]
        return bool((np.einsum("ij,ij->i", diff, diff) <= JOIN_EPSILON**2).any())

    # The grids are independent (a sort each: ~0.01 s at 5 * 10^5 rows): on every core.
    return any(ordered(near_in_grid, range(_GRIDS)))


def _joined(path, corners, fields, tables, need_normals, tri=None) -> RawMesh:
    """Assimp's one mesh: corners joined where all their values are equal, numbered in file
    order of first use; ``tri``: (T, 3) corner numbers of the triangles (None: corners 3 by 3)."""
    n = len(corners)
    key = np.zeros(n, np.int64)
    span = 1
    for j, f in enumerate(fields):
        ids = _first_equal_rows(tables[f])
        if span * len(tables[f]) >= 2**62:
            raise Unsupported("index tables too large to combine")
        # No equal rows: every index is its own row's (a gather of 3 * 10^6 indices saved).
        key += (corners[:, j] if ids is None else ids[corners[:, j]]) * span
        span *= len(tables[f])
    first = np.full(int(key.max()) + 1, n, np.int64)
    np.minimum.at(first, key, np.arange(n))
    used = np.flatnonzero(first < n)
    vert_keys = used[np.argsort(first[used], kind="stable")]  # runs of first uses: timsort's best case
    remap = np.empty(len(first), np.int64)
    remap[vert_keys] = np.arange(len(vert_keys))
    rep = take_rows(corners, first[vert_keys])  # the corner that first uses each vertex: its values are kept
    col = dict(zip(fields, rep.T))
    normals = None
    if need_normals and _VN in col:
        normals = take_rows(tables[_VN], col[_VN]).astype(np.float64)
    uvs = None
    if _VT in col:
        uvs = take_rows(tables[_VT], col[_VT])[:, :2].astype(np.float64)
    part = RawPart(label="sub-mesh #0 'defaultobject'", vertices=take_rows(tables[_V], col[_V]).astype(np.float64),
                   indices=remap[key] if tri is None else remap[key][tri].ravel(), material=0,
                   normals=normals, uvs=uvs)
    # Assimp invents "DefaultMaterial" for faces without usemtl (assimp_file._materials gives it
    # no colour: nothing came from a file).
    return RawMesh(path, [part], [MeshMaterial(name="DefaultMaterial")])

"""Assimp's JoinIdenticalVertices on the tables of an OBJ file that mcpt/shapes/obj_fast.py read
(issue #23): the face corners joined where position, normal and UV agree, numbered in order of
first use, bit for bit as Assimp 5.4 joins them (code/PostProcessing/JoinVerticesProcess.cpp).

Assimp joins two corners whose values lie within 1e-5 of each other (the first corner's values
kept). Two *different* values that close are joined only when their hashes meet in a bucket of
Assimp's hash map, which cannot be predicted here: such a file (:func:`_near_pairs`) goes to
Assimp. Otherwise the join is an exact one (-0.0 = 0.0), done on the file's index tables.
"""

from __future__ import annotations

import numpy as np

from ..parallel import ordered
from .dedup import first_equal
from .obj_numbers import VN, VT, Unsupported, V
from .raw_mesh import MeshMaterial, RawMesh, RawPart
from .rows import take_rows

#: Assimp's vertex-join tolerance (JoinVerticesProcess.cpp, ``epsilon``), widened a little so that
#: float32 rounding in Assimp's own test can never join a pair this check lets through.
JOIN_EPSILON = 1.1e-5
#: Shifted grids of the join check (_near_pairs): more than the 3 axes of a table.
_GRIDS = 4


def _first_equal_rows(table: np.ndarray) -> np.ndarray | None:
    """For every row of a float32 table, the index of the first row equal to it as floats
    (-0.0 equals 0.0: libstdc++ hashes both to 0, so Assimp joins them; joined keeps the bits
    of the corner that uses the value first, as Assimp does); None when every row is its own
    first (no two rows equal: the usual case). Raises Unsupported for a pair of near rows
    (:func:`_near_pairs`)."""
    canon = table + np.float32(0.0)  # -0.0 + 0.0 = +0.0
    ids = first_equal(np.ascontiguousarray(canon).view(np.uint32))
    if ids is None:
        raise Unsupported("hash collision")  # different rows, one 64-bit hash: let Assimp join
    distinct = ids == np.arange(len(ids))
    every = bool(distinct.all())
    if _near_pairs(table if every else table[distinct]):
        raise Unsupported("values within Assimp's join tolerance")
    return None if every else ids


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
        return True  # coordinates past ~1.6e13: int64 keys could wrap; Assimp decides
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


def joined(path, corners, fields, tables, need_normals, tri=None) -> RawMesh:
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
    # The corners that first use a vertex, in file order: their keys are the vertices in order of
    # first use (no sort of the first uses: 27 ms at 10^6 triangles, issue #23).
    is_first = np.zeros(n, bool)
    is_first[first[first < n]] = True
    first_corner = np.flatnonzero(is_first)
    vert_keys = key[first_corner]
    remap = np.empty(len(first), np.int64)
    remap[vert_keys] = np.arange(len(vert_keys))
    rep = take_rows(corners, first_corner)  # the corner that first uses each vertex: its values are kept
    col = dict(zip(fields, rep.T))
    normals = None
    if need_normals and VN in col:
        normals = take_rows(tables[VN], col[VN]).astype(np.float64)
    uvs = None
    if VT in col:
        uvs = take_rows(tables[VT], col[VT])[:, :2].astype(np.float64)
    part = RawPart(label="sub-mesh #0 'defaultobject'", vertices=take_rows(tables[V], col[V]).astype(np.float64),
                   indices=remap[key] if tri is None else remap[key][tri].ravel(), material=0,
                   normals=normals, uvs=uvs)
    # Assimp invents "DefaultMaterial" for faces without usemtl (assimp_file._materials gives it
    # no colour: nothing came from a file).
    return RawMesh(path, [part], [MeshMaterial(name="DefaultMaterial")])

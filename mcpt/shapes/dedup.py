"""Repeated triangles: the same surface listed twice (within a file, or across files of a scene).

A light listed twice would be two lights for next-event estimation but one surface for BSDF hits,
counting its direct light twice; a duplicated surface also costs BVH space. mcpt/shapes/mesh.py
drops repeats within a file (by vertex index), mcpt/shapes/world.py across files (by float32 corners).

Both find repeats by hashing each triangle's canonical rotation into one 64-bit key and sorting the
keys (numpy's sort of 10^6 uint64 takes milliseconds), not by sorting whole rows (np.unique with
``axis=0``: seconds on 10^6 triangles, issue #23). Keys that collide are compared in full, so the
result is exact: the same indices the row sort gives.
"""

from __future__ import annotations

import numpy as np

from ..parallel import ordered, row_chunks

# splitmix64's finaliser constants (Steele, Lea & Flood 2014): every input bit reaches every output bit.
_MIX1, _MIX2 = np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB)
_PRIME = np.uint64(0x100000001B3)  # FNV-1a's 64-bit prime: the per-word step of the row hash


def first_of_duplicates(faces: np.ndarray) -> np.ndarray:
    """Sorted indices of the first occurrence of every triangle, equal up to a cyclic rotation
    of its corners (index based: Assimp's JoinIdenticalVertices gives equal corners equal indices)."""
    if len(faces) < 2:
        return np.arange(len(faces))
    # Only faces whose order-free key (a sum of the corners' mixed indices) repeats can repeat
    # (first_of_repeated_corners' reasoning): usually none (0.04 s against 0.08-0.11 s for the
    # canonical rotation's row hash on the 10^6-triangle sphere, issue #23). Plain sums of the
    # indices and of their squares met for a fifth of that sphere's faces: mixed, none.
    key = np.zeros(len(faces), np.uint64)
    with np.errstate(over="ignore"):
        for j in range(3):
            key += _mixed(faces[:, j].astype(np.uint64))
    return _first_of_suspects(key, faces, _first_of_rotated)


def _mixed(x: np.ndarray) -> np.ndarray:
    """uint64 words with their bits spread (splitmix64-style, wrapping)."""
    with np.errstate(over="ignore"):
        h = x * _MIX1
        h ^= h >> np.uint64(29)
        h *= _MIX2
        h ^= h >> np.uint64(32)
    return h


def _first_of_rotated(faces: np.ndarray) -> np.ndarray:
    """first_of_duplicates by the canonical rotation's row hash."""
    r = np.argmin(faces, axis=1)
    canon = np.take_along_axis(faces, (r[:, None] + np.arange(3)) % 3, axis=1).astype(np.int64)
    return first_of_rows(canon)


def first_of_repeated_corners(tris32: np.ndarray) -> np.ndarray:
    """Sorted indices of the first occurrence of every (F, 3, 3) float32 triangle, equal bit for
    bit up to a cyclic rotation of its corners. Corners are ordered as their (x, y, z) uint32
    words, lexicographically; the rotation starts at the first smallest corner."""
    w = np.ascontiguousarray(tris32, dtype=np.float32).view(np.uint32)
    if len(w) < 2:
        return np.arange(len(w))
    # A key that any order of the corners leaves unchanged (_corner_sum_key): equal triangles
    # have equal keys, so only triangles whose key repeats can repeat, and the first of each lies
    # among them. Usually none does: no canonical rotation (0.085-0.097 s against 0.09-0.14 s for
    # the cyclic hash at 10^6 triangles, and nothing copied; issue #23).
    return _first_of_suspects(_corner_sum_key(w), w, _first_of_cyclic)


def _first_of_suspects(key: np.ndarray, items: np.ndarray, exact) -> np.ndarray:
    """Sorted indices of the first of every distinct item, given a key that equal items share:
    ``exact`` (items -> sorted first indices) runs only on the items whose key repeats."""
    s = np.sort(key)
    same = s[1:] == s[:-1]
    if not same.any():
        return np.arange(len(items))
    suspects = np.flatnonzero(np.isin(key, s[1:][same]))
    if suspects.size == len(items):
        return exact(items)
    keep = np.ones(len(items), bool)
    keep[suspects] = False
    keep[suspects[exact(items[suspects])]] = True
    return np.flatnonzero(keep)


def _corner_sum_key(w: np.ndarray) -> np.ndarray:
    """(F,) uint64 key of (F, 3, 3) corner words, the same for every order of the corners: the
    sum over the corners of each corner's mixed words (sums of the raw words meet structurally
    on lattices, where float bits are affine in the value within a binade)."""
    key = np.zeros(len(w), np.uint64)

    def fill(rows: slice) -> None:  # triangle by triangle: a chunk per core (issue #23)
        part = key[rows]
        with np.errstate(over="ignore"):
            for c in range(3):
                h = _mixed(w[rows, c, 0].astype(np.uint64) << np.uint64(32) | w[rows, c, 1])
                part += _mixed(h ^ w[rows, c, 2])

    ordered(fill, row_chunks(len(w)))
    return key


def _first_of_cyclic(w: np.ndarray) -> np.ndarray:
    """first_of_repeated_corners of (F, 3, 3) corner words, by the cyclic hash."""
    s = np.sort(_cyclic_hash(w))
    if not (s[1:] == s[:-1]).any():
        # Equal triangles (up to rotation) hash equal: no equal hashes, no repeats.
        return np.arange(len(w))
    c0, c1, c2 = w[:, 0], w[:, 1], w[:, 2]
    # Strictly smaller than the smallest so far: ties keep the first corner (np.argmin's rule).
    r1 = _less(c1, c0)
    r2 = _less(c2, np.where(r1[:, None], c1, c0))
    canon = np.empty((len(w), 3, 3), np.uint32)
    for j, (a, b, c) in enumerate(((c0, c1, c2), (c1, c2, c0), (c2, c0, c1))):
        canon[:, j] = np.where(r2[:, None], c, np.where(r1[:, None], b, a))
    return first_of_rows(canon.reshape(len(w), 9))


def _cyclic_hash(w: np.ndarray) -> np.ndarray:
    """(F,) uint64 hash of (F, 3, 3) corner words that a cyclic rotation of the corners leaves
    unchanged but a reversal (the other winding) does not: a sum over the three (corner, next
    corner) pairs of a non-symmetric mix of the two corners' hashes."""
    h = [row_hash(w[:, j]) for j in range(3)]
    total = np.zeros(len(w), np.uint64)
    with np.errstate(over="ignore"):
        for j in range(3):
            pair = h[j] * _PRIME ^ h[(j + 1) % 3]
            pair ^= pair >> np.uint64(31)
            pair *= _MIX1
            pair ^= pair >> np.uint64(29)
            total += pair
    return total


def _less(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise lexicographic a < b for (N, 3) unsigned words."""
    return (a[:, 0] < b[:, 0]) | ((a[:, 0] == b[:, 0]) & (
        (a[:, 1] < b[:, 1]) | ((a[:, 1] == b[:, 1]) & (a[:, 2] < b[:, 2]))))


def row_hash(rows: np.ndarray) -> np.ndarray:
    """(N,) uint64 hash of each row of an (N, K) integer array (wrapping arithmetic)."""
    h = np.full(len(rows), 0xCBF29CE484222325, np.uint64)
    with np.errstate(over="ignore"):
        for k in range(rows.shape[1]):  # a column at a time: no (N, K) uint64 copy
            h ^= rows[:, k].astype(np.uint64)
            h *= _PRIME
        h ^= h >> np.uint64(30)
        h *= _MIX1
        h ^= h >> np.uint64(27)
        h *= _MIX2
        h ^= h >> np.uint64(31)
    return h


def first_equal(rows: np.ndarray) -> np.ndarray | None:
    """For every row of an (N, K) integer array, the index of the first row equal to it; None
    when two different rows share a 64-bit hash (the caller then takes an exact path)."""
    n = len(rows)
    h = row_hash(rows)
    s = np.sort(h)
    if not (s[1:] == s[:-1]).any():  # the common case: all keys differ, so all rows do
        return np.arange(n)
    order = np.argsort(h, kind="stable")  # stable: the first of a run is the earliest occurrence
    hs = h[order]
    new = np.ones(n, bool)
    new[1:] = hs[1:] != hs[:-1]
    rep = order[np.maximum.accumulate(np.where(new, np.arange(n), 0))]
    if (rows[order] != rows[rep]).any():
        return None
    ids = np.empty(n, np.int64)
    ids[order] = rep
    return ids


def first_of_rows(rows: np.ndarray) -> np.ndarray:
    """Sorted indices of the first occurrence of every distinct row of an (N, K) integer array."""
    ids = first_equal(rows)
    if ids is None:
        return _first_of_rows_sorted(rows)  # a hash collision between different rows: exact path
    return np.flatnonzero(ids == np.arange(len(rows)))


def _first_of_rows_sorted(rows: np.ndarray) -> np.ndarray:
    """first_of_rows by a lexicographic row sort (slow; only for colliding hashes)."""
    order = np.lexsort(rows.T[::-1])
    c = rows[order]
    new = np.ones(len(c), bool)
    new[1:] = np.any(c[1:] != c[:-1], axis=1)
    return np.sort(order[new])

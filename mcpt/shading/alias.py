"""Alias tables (Walker 1977, Vose 1991; pbrt-v4 sec. A.1 "The Alias Method"): sampling a discrete
distribution in O(1), one table entry read per sample, for the environment map's rows of cells
and the cells of each row (mcpt/shading/envmap.py, glsl/envmap.glsl env_alias_pick).

A table of n buckets (n a power of two, so that ``u n`` and its fraction are exact in float32)
holds per bucket b a threshold q_b in [0, 1] and an alias a_b: a uniform u picks bucket
b = floor(u n), and its fraction f = u n - b picks b itself when f < q_b, else a_b; the fraction
is then remapped to [0, 1) (f / q_b or (f - q_b) / (1 - q_b)) and reused to place the point inside
the chosen item. The probability of item k is (q_k + sum over {b: a_b = k} (1 - q_b)) / n,
computed by :func:`realised` from the float32 thresholds the shader compares against, so the pdf
the renderer uses is the one its samples have whatever the construction's rounding.

Construction: Vose's pairing in closed form, every row at once (a Python loop over millions of
texels would take seconds; the earlier rounds of pairings took 0.3 s for a 2048 x 1024 map). With
the mean scaled to 1 per bucket, the "small" items (q < 1) lay their deficits 1 - q end to end on
one line, [D_(i-1), D_i), and the "large" ones (q > 1) their surpluses q - 1 on another,
[E_(j-1), E_j), both as long as the row's total. Sweeping through the large items in order (a
large item takes small items until its surplus is spent, then its own deficit goes to the next
large item: the sequential "sweep" of Huebschle-Schneider & Sanders 2019, "Parallel weighted
random sampling", ESA 2019) has a closed form:

* small item i aliases the large item j whose surplus interval holds the start of its deficit,
  E_(j-1) <= D_(i-1) < E_j, and keeps its q;
* large item j aliases the next large item, j + 1, with q_j = 1 - (D_k - E_j), D_k the first
  small end >= E_j (the small item its surplus runs out in; q_j = 1 if there is none, and for
  the row's last large item).

Large item j then receives the small items from the one after j - 1's D_k to its own D_k, plus
j - 1's overflow D_k' - E_(j-1): in all D_k - E_(j-1), and keeps q_j: 1 + E_j - E_(j-1), its
weight. One sorted search finds every D_k (numpy.searchsorted); counting the k_j <= i - 1 gives
each small item's j. The lines are int64 fixed point (2^-40 of a bucket; 2^-33 at 2^26 texels)
so that each row sits on its own stretch of one line exactly: with a float offset per row the
comparisons that the bookkeeping above relies on would round. Float32 weights (the environment
map's) are kept float32 (q rounded once from a float64 product): half the memory traffic of the
steps that touch every bucket, and q is then the very threshold the shader compares against.
"""

from __future__ import annotations

import numpy as np


def padded_size(n: int) -> int:
    """The power of two >= n (>= 1): the table's bucket count (glsl/envmap.glsl env_pow2)."""
    return 1 << max(int(n) - 1, 0).bit_length()


def build_alias(weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Alias tables of the rows of ``weights`` (R, n) >= 0 (float32 kept as it is, anything else
    as float64), each row's sum > 0, padded with zero-weight buckets to n' = :func:`padded_size`
    (n). Returns (q (R, n') float32 thresholds, alias (R, n') int32 item indices < n)."""
    w = np.asarray(weights)
    w = w if w.dtype == np.float32 else w.astype(np.float64, copy=False)
    rows, n = w.shape
    size = padded_size(n)
    # q (mean 1 a bucket) in the weights' precision: float32 weights give float32 q, the very
    # thresholds the shader reads (a small item keeps its q), and half the memory traffic. The
    # product is taken in float64 and rounded once (a float32 scale would tilt a whole row by its
    # own rounding, all of which the row's last large item would absorb).
    q = np.zeros((rows, size), w.dtype)                  # padding buckets weigh 0
    np.multiply(w, (size / w.sum(axis=1, dtype=np.float64))[:, None], out=q[:, :n], casting="unsafe")
    alias = np.tile(np.arange(size, dtype=np.int32), rows)
    qf = q.reshape(-1)
    si, li = np.flatnonzero(qf < 1.0), np.flatnonzero(qf > 1.0)   # q == 1 exactly: its own bucket
    # Each row's first small and large item (the lists are sorted by row): no per-row pass.
    starts = np.arange(rows + 1, dtype=np.int64) * size
    sfirst, lfirst = np.searchsorted(si, starts), np.searchsorted(li, starts)
    n_small, n_large = np.diff(sfirst), np.diff(lfirst)
    if si.size == 0 or li.size == 0:                     # all q within rounding of 1
        return _close_out(q, alias.reshape(rows, size), w, n, np.arange(rows))
    # Fixed point (unit = one bucket): a row's lines are <= size + 1 units long (the +1: slack
    # given to the row's last large item, whose q is 1 anyway, so that no small item's start
    # passes the row's surplus by rounding); rows lie ``span`` units apart on one line each.
    # Rounding: + 0.5 then truncation (the values are >= 0), 3x faster than numpy.rint.
    span = 2 * size + 4
    unit = 2 ** min(40, 62 - (rows * span).bit_length())
    deficit = np.multiply(qf[si], -float(unit), dtype=np.float64)
    deficit += unit + 0.5
    deficit = deficit.astype(np.int64)
    surplus = np.multiply(qf[li], float(unit), dtype=np.float64)
    surplus -= unit - 0.5
    surplus = surplus.astype(np.int64)
    np.maximum(surplus, 1, out=surplus)                  # E strictly rising
    last = lfirst[1:][n_large > 0] - 1                   # each row's last large item
    surplus[last] += unit
    base = np.arange(rows, dtype=np.int64) * (span * unit)
    s_key = _keys(deficit, n_small, sfirst, base)        # row offset + D_i, the small items' ends
    l_key = _keys(surplus, n_large, lfirst, base)        # row offset + E_j, the large items' ends
    # Large item j: the first small end at or past E_j (k, its index; past the row: q = 1).
    k = np.searchsorted(s_key, l_key, side="left")
    over = np.take(s_key, k, mode="clip") - l_key        # its overflow into small item k
    over[(over < 0) | (over > unit)] = 0                 # k past the row's end: q = 1
    over[last] = 0
    qf[li] = over * (-1.0 / unit) + 1.0                  # unit: 2^m, the product exact
    nxt = np.empty_like(li)                              # large j aliases j + 1 (its row's last: j)
    nxt[:-1] = li[1:]
    nxt[last] = li[last]
    alias[li] = np.bitwise_and(nxt, size - 1, out=nxt)   # the column (size: 2^m)
    # Small item i starts where i - 1 ends: its large item is the first j with E_j > D_(i-1),
    # the count of j with k_j <= i - 1 (k rises with j); a row's first small item starts at 0.
    pick = np.empty(si.size, np.int64)
    pick[0] = 0
    np.cumsum(np.bincount(k, minlength=si.size)[: si.size - 1], out=pick[1:])
    has_small = n_small > 0
    pick[sfirst[:-1][has_small]] = lfirst[:-1][has_small]
    np.bitwise_and(li, size - 1, out=li)                 # li's columns from here on
    alias[si] = np.take(li, pick, mode="clip")
    alias = alias.reshape(rows, size)
    lone = np.flatnonzero((n_large == 0) & has_small)
    # q is in [0, 1] by construction: small items' q < 1, large ones' 1 - over / unit.
    return _close_out(q, alias, w, n, lone) if lone.size else _tables(q, alias)


def _keys(values: np.ndarray, counts: np.ndarray, first: np.ndarray, base: np.ndarray) -> np.ndarray:
    """Running sums of the int64 ``values`` (row by row, ``counts`` per row, a row's first at
    ``first``), restarted at each row and shifted to the row's ``base``: exact integers, sorted
    across rows."""
    total = np.cumsum(values)
    before = np.r_[0, total][first[:-1]]
    total += np.repeat(base - before, counts)
    return total


def _close_out(q, alias, w, n, rows) -> tuple[np.ndarray, np.ndarray]:
    """Rows without a small or a large item (every q rounded to just below or above 1): each item
    keeps its bucket (q = 1); a padding bucket goes whole to the row's heaviest item."""
    q[rows, :n] = 1.0
    q[rows, n:] = 0.0
    alias[rows, :n] = np.arange(n)
    alias[rows, n:] = np.argmax(w[rows], axis=1)[:, None]
    return _tables(q, alias)


def _tables(q, alias) -> tuple[np.ndarray, np.ndarray]:
    return q.astype(np.float32, copy=False), alias


def realised(q: np.ndarray, alias: np.ndarray, n: int) -> np.ndarray:
    """(R, n) float64 probability of each item under the tables (R, n') as sampled: bucket b
    gives q_b / n' to b and (1 - q_b) / n' to a_b."""
    rows, size = q.shape
    flat = alias + (np.arange(rows, dtype=np.int64) * size)[:, None]
    p = np.bincount(flat.ravel(), np.subtract(1.0, q, dtype=np.float64).ravel(), minlength=rows * size)
    p = p.reshape(rows, size)
    p += q
    p *= 1.0 / size                                      # size: 2^m, exact
    return p[:, :n]

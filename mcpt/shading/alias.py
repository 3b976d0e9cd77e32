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
comparisons that the bookkeeping above relies on would round.
"""

from __future__ import annotations

import numpy as np


def padded_size(n: int) -> int:
    """The power of two >= n (>= 1): the table's bucket count (glsl/envmap.glsl env_pow2)."""
    return 1 << max(int(n) - 1, 0).bit_length()


def build_alias(weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Alias tables of the rows of ``weights`` (R, n) >= 0, each row's sum > 0, padded with
    zero-weight buckets to n' = :func:`padded_size` (n). Returns (q (R, n') float32 thresholds,
    alias (R, n') int64 item indices < n)."""
    w = np.asarray(weights, np.float64)
    rows, n = w.shape
    size = padded_size(n)
    q = w * (size / w.sum(axis=1, keepdims=True))        # mean 1 per bucket
    if size > n:                                         # padding buckets weigh 0
        q = np.concatenate([q, np.zeros((rows, size - n))], axis=1)
    alias = np.broadcast_to(np.arange(size), (rows, size)).copy()
    qf, af = q.reshape(-1), alias.reshape(-1)
    small, large = q < 1.0, q > 1.0                      # q == 1 exactly: its own bucket
    si, li = np.flatnonzero(small), np.flatnonzero(large)
    n_small, n_large = small.sum(axis=1), large.sum(axis=1)
    if si.size == 0 or li.size == 0:                     # all q within rounding of 1
        return _close_out(q, alias, w, n, np.arange(rows))
    # Fixed point (unit = one bucket): a row's lines are <= size + 1 units long (the +1: slack
    # given to the row's last large item, whose q is 1 anyway, so that no small item's start
    # passes the row's surplus by rounding); rows lie ``span`` units apart on one line each.
    span = 2 * size + 4
    unit = 2 ** min(40, 62 - (rows * span).bit_length())
    deficit = np.rint((1.0 - qf[si]) * unit).astype(np.int64)
    surplus = np.maximum(np.rint((qf[li] - 1.0) * unit).astype(np.int64), 1)  # E strictly rising
    lfirst = np.r_[0, np.cumsum(n_large)]
    surplus[lfirst[1:][n_large > 0] - 1] += unit
    base = np.arange(rows, dtype=np.int64) * (span * unit)
    s_key = _keys(deficit, n_small, base)                # row offset + D_i, the small items' ends
    l_key = _keys(surplus, n_large, base)                # row offset + E_j, the large items' ends
    # Large item j: the first small end at or past E_j (k, its index; past the row: q = 1).
    k = np.searchsorted(s_key, l_key, side="left")
    over = np.take(s_key, k, mode="clip") - l_key
    same = np.ones(li.size, bool)                        # j + 1 is in j's row
    same[lfirst[1:][n_large > 0] - 1] = False
    qf[li] = np.where(same & (over >= 0) & (over <= unit), 1.0 - over / unit, 1.0)
    af[li] = np.where(same, np.r_[li[1:], 0], li) & (size - 1)   # the column (size: 2^m)
    # Small item i starts where i - 1 ends: its large item is the first j with E_j > D_(i-1),
    # the count of j with k_j <= i - 1 (k rises with j); a row's first small item starts at 0.
    pick = np.r_[0, np.cumsum(np.bincount(k, minlength=si.size))[: si.size - 1]]
    sfirst = np.r_[0, np.cumsum(n_small)][:-1]
    pick[sfirst[n_small > 0]] = lfirst[:-1][n_small > 0]
    af[si] = np.take(li, pick, mode="clip") & (size - 1)
    lone = np.flatnonzero((n_large == 0) & (n_small > 0))
    return _close_out(q, alias, w, n, lone) if lone.size else _tables(q, alias)


def _keys(values: np.ndarray, counts: np.ndarray, base: np.ndarray) -> np.ndarray:
    """Running sums of the int64 ``values`` (row by row, ``counts`` per row), restarted at each
    row and shifted to the row's ``base``: exact integers, sorted across rows."""
    total = np.cumsum(values)
    before = np.r_[0, total][np.r_[0, np.cumsum(counts)][:-1]]
    return total + np.repeat(base - before, counts)


def _close_out(q, alias, w, n, rows) -> tuple[np.ndarray, np.ndarray]:
    """Rows without a small or a large item (every q rounded to just below or above 1): each item
    keeps its bucket (q = 1); a padding bucket goes whole to the row's heaviest item."""
    q[rows, :n] = 1.0
    q[rows, n:] = 0.0
    alias[rows, :n] = np.arange(n)
    alias[rows, n:] = np.argmax(w[rows], axis=1)[:, None]
    return _tables(q, alias)


def _tables(q, alias) -> tuple[np.ndarray, np.ndarray]:
    return np.clip(q, 0.0, 1.0).astype(np.float32), alias


def realised(q: np.ndarray, alias: np.ndarray, n: int) -> np.ndarray:
    """(R, n) float64 probability of each item under the tables (R, n') as sampled: bucket b
    gives q_b / n' to b and (1 - q_b) / n' to a_b."""
    rows, size = q.shape
    qd = q.astype(np.float64)
    p = qd.copy()
    flat = (np.arange(rows)[:, None] * size + alias).ravel()
    p += np.bincount(flat, (1.0 - qd).ravel(), minlength=rows * size).reshape(rows, size)
    return p[:, :n] / size

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

Construction: Vose's small/large pairing, vectorised (a Python loop over millions of texels
would take seconds) in rounds: the deficits 1 - q of the "small" items and the surpluses q - 1 of
the "large" ones are laid end to end along two lines of equal length; each small item takes as
its alias the large item whose surplus interval holds the start of its deficit interval, and
that large item is charged the whole deficit (it may then fall below 1 and become small in the
next round). Every round finalises all current small items; a handful of rounds suffice.
"""

from __future__ import annotations

import numpy as np

#: Rounds before the leftovers (rounding crumbs) are closed with q = 1 (they alias themselves).
MAX_ROUNDS = 64


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
    q = np.zeros((rows, size), np.float64)
    q[:, :n] = w * (size / w.sum(axis=1, keepdims=True))  # mean 1 per bucket
    alias = np.broadcast_to(np.arange(size), (rows, size)).copy()
    qf, af = q.reshape(-1), alias.reshape(-1)
    live = np.arange(rows * size)  # the unfinished buckets, row-major (flat indices)
    for _ in range(MAX_ROUNDS):
        r = live // size
        ql = qf[live]
        small = ql < 1.0
        ls, ll = np.flatnonzero(small), np.flatnonzero(~small)
        if ls.size == 0 or ll.size == 0:
            break
        # Row-wise running sums over the unfinished buckets only (a round costs what is left):
        # the start of each small item's deficit, the end of each large item's surplus.
        head = np.flatnonzero(np.r_[True, r[1:] != r[:-1]])          # each row's first position
        tail = np.r_[head[1:], r.size] - 1                           # and last
        count = np.diff(np.r_[head, r.size])
        deficit = np.where(small, 1.0 - ql, 0.0)
        surplus = np.where(small, 0.0, ql - 1.0)
        cd, ce = np.cumsum(deficit), np.cumsum(surplus)
        base = np.repeat(np.arange(head.size) * (2.0 * size + 4.0), count)  # rows apart
        start = (cd - deficit - np.repeat(cd[head] - deficit[head], count) + base)[ls]
        end = (ce - np.repeat(ce[head] - surplus[head], count) + base)[ll]
        # Each small item's large partner: the first whose end passes its start (one merge of
        # two sorted runs; ends first, so an end equal to a start counts as passed).
        order = np.argsort(np.r_[end, start], kind="stable")
        passed = np.cumsum(order < ll.size)
        pick = np.empty(ls.size, np.int64)
        pick[order[order >= ll.size] - ll.size] = passed[order >= ll.size]
        # Clamped to the row's last large item (a start may pass the row's surplus by rounding);
        # a row without large items keeps its small ones for the close-out.
        n_large = np.cumsum(~small)
        row_of = np.repeat(np.arange(head.size), count)[ls]
        last = n_large[tail[row_of]] - 1
        ok = n_large[tail[row_of]] > n_large[head[row_of]] - (~small[head[row_of]])
        if not ok.any():
            break
        ls, pick = ls[ok], ll[np.minimum(pick[ok], last[ok])]
        af[live[ls]] = live[pick] % size
        qf[live] = ql - np.bincount(pick, deficit[ls], minlength=live.size)
        keep = np.ones(live.size, bool)
        keep[ls] = False
        live = live[keep]
    active = np.zeros(rows * size, bool)
    active[live] = True
    active = active.reshape(rows, size)
    # Leftovers (large items, or rounding crumbs with no partner left) keep their own bucket; a
    # padding bucket left over goes whole to its row's heaviest item.
    r, c = np.nonzero(active)
    pad = c >= n
    q[r, c] = np.where(pad, 0.0, 1.0)
    alias[r, c] = np.where(pad, np.argmax(w, axis=1)[r], c)
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

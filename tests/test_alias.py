"""Alias tables (mcpt/shading/alias.py): the tables realise the weights they were built from,
zero weights and padding buckets are unreachable, and the numpy pick (the shader's steps,
mcpt/shading/envmap.py _alias_pick) draws items with those probabilities (chi-square)."""

from __future__ import annotations

import numpy as np
import pytest

from mcpt.shading.alias import build_alias, padded_size, realised
from mcpt.shading.envmap import _alias_pick

from .test_materials_util import chi2_test, uniform_numbers

CASES = {
    "random": lambda rng: rng.random((7, 100)),
    "spike": lambda rng: np.r_[np.ones(127), 1e6][None],          # one bucket feeds all others
    "zeros": lambda rng: np.r_[np.zeros(10), 1.0, np.zeros(5)][None],
    "steep": lambda rng: rng.random((31, 129)) ** 12,
    "power-of-two": lambda rng: rng.random((3, 64)),
}


@pytest.mark.parametrize("name", list(CASES))
def test_tables_realise_the_weights(name):
    w = CASES[name](np.random.default_rng(len(name)))
    q, alias = build_alias(w)
    n = w.shape[1]
    assert q.shape == alias.shape == (w.shape[0], padded_size(n)) and q.dtype == np.float32
    assert ((q >= 0) & (q <= 1)).all() and (alias >= 0).all() and (alias < n).all()
    assert (q[:, n:] == 0).all(), "a padding bucket picks itself"
    p = realised(q, alias, n)
    np.testing.assert_allclose(p, w / w.sum(axis=1, keepdims=True), rtol=1e-5, atol=1e-7)
    assert (p[w == 0] == 0).all()


def test_padded_size():
    assert [padded_size(n) for n in (1, 2, 3, 63, 64, 65, 1000)] == [1, 2, 4, 64, 64, 128, 1024]


def test_pick_draws_the_realised_probabilities():
    w = np.random.default_rng(3).random((1, 77)) ** 6
    q, alias = build_alias(w)
    n = 1 << 18
    u = uniform_numbers(n, 1, seed=9)[:, 0].astype(np.float32)
    item, t = _alias_pick(u, q[0], alias[0])
    assert ((t >= 0) & (t <= 1)).all()
    p_val, stat, dof = chi2_test(np.bincount(item, minlength=77), realised(q, alias, 77)[0] * n)
    assert p_val > 0.001, f"chi2 = {stat:.1f} for {dof} dof, p = {p_val:.3g}"
    # The remainder is uniform within the chosen item (quartiles of the heaviest item).
    top = item == np.argmax(w)
    quart = np.bincount(np.minimum((t[top] * 4).astype(int), 3), minlength=4)
    p_val, stat, dof = chi2_test(quart, np.full(4, top.sum() / 4.0))
    assert p_val > 0.001, f"remainder: chi2 = {stat:.1f}, p = {p_val:.3g}"


def _degenerate_rows(n: int, rng) -> np.ndarray:
    """Rows that stress the bookkeeping, stacked in one call (their lines share one int64 line):
    equal weights (q exactly 1, or rounded just under / over 1), a large item whose surplus
    rounds to 0 ahead of the first small one, a single non-zero cell at the
    start, middle and end, zeros between spikes, a 10^30 dynamic range, and random rows."""
    rows = [np.full(n, 1.0), np.full(n, 0.1), np.full(n, 1.0 / 3.0)]
    near = np.full(n, 1.0)
    near[:4] = [1.0 + 3e-13, 0.5, 1.5, 1.0 - 3e-13][:n]  # a surplus below the fixed point's unit
    rows.append(near)
    for k in (0, n // 2, n - 1):
        one = np.zeros(n)
        one[k] = 2.5
        rows.append(one)
    spikes = np.zeros(n)
    spikes[::7] = rng.random(spikes[::7].size) + 0.5
    rows += [spikes, 10.0 ** rng.uniform(-30.0, 0.0, n), rng.random(n), rng.random(n) ** 8]
    return np.array(rows)


@pytest.mark.parametrize("n", [1, 2, 3, 5, 64, 65, 100, 2048])
def test_degenerate_rows_realise_their_weights_to_float32_precision(n):
    w = _degenerate_rows(n, np.random.default_rng(n))
    q, alias = build_alias(w)
    assert q.shape == (w.shape[0], padded_size(n))
    assert ((q >= 0) & (q <= 1)).all() and (alias >= 0).all() and (alias < n).all()
    assert (q[:, n:] == 0).all(), "a padding bucket picks itself"
    p = realised(q, alias, n)
    target = w / w.sum(axis=1, keepdims=True)
    assert (p[w == 0] == 0).all(), "a zero weight is reachable"
    # float32 thresholds: each bucket's share is exact to ~2^-24 of a bucket; an item gathers
    # one share per bucket aliasing it, so compare against the item's own size in buckets.
    np.testing.assert_allclose(p, target, rtol=3e-7, atol=0.0)


def test_rows_do_not_interfere():
    """A row's table realises its weights whatever the rows before and after it hold (they share
    one line): a row built alone and inside a stack of others gives the same probabilities."""
    rng = np.random.default_rng(5)
    w = np.vstack([rng.random((3, 300)) ** 20, np.r_[np.zeros(299), 1.0], rng.random((3, 300))])
    p = realised(*build_alias(w), 300)
    for r in range(w.shape[0]):
        np.testing.assert_allclose(p[r], realised(*build_alias(w[r: r + 1]), 300)[0], rtol=3e-7, atol=0.0)


@pytest.mark.parametrize("n", [3, 65, 2048])
def test_float32_weights_realise_their_weights_to_float32_precision(n):
    """float32 weights (the environment map's) build float32 q directly: the same tables'
    guarantees, to float32 precision. Each q rounds to float32 before the sweep, so a row's q add
    up to n' only within the row's float32 roundings (at most 2^-24 of the row's probability),
    which the row's last large item absorbs; a small item (q < 1) keeps its own q."""
    w = _degenerate_rows(n, np.random.default_rng(n + 1)).astype(np.float32)
    q, alias = build_alias(w)
    assert q.dtype == np.float32 and ((q >= 0) & (q <= 1)).all() and (alias >= 0).all() and (alias < n).all()
    assert (q[:, n:] == 0).all(), "a padding bucket picks itself"
    p = realised(q, alias, n)
    w64 = w.astype(np.float64)
    assert (p[w == 0] == 0).all(), "a zero weight is reachable"
    target = w64 / w64.sum(axis=1, keepdims=True)
    small = target < 1.0 / padded_size(n)
    np.testing.assert_allclose(p[small], target[small], rtol=3e-7, atol=0.0)
    np.testing.assert_allclose(p, target, rtol=3e-7, atol=2.0**-24)

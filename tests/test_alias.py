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

"""Draw copies (mcpt/gpu/draw_copies.py, glsl/draw_copies.frag): how many an image gets, and that
drawing a small image as side-by-side copies (each taking every K-th sample of the draw) gives
the image of one copy taking them all, up to float32 summation order."""

from __future__ import annotations

import numpy as np

from mcpt.api import prepare
from mcpt.gpu.draw_copies import draw_copies

from .conftest import ROOT
from .draw import render as draw

CORNELL = ROOT / "scenes" / "cornell-box.yaml"


def test_copies_only_where_the_image_spans_few_tiles():
    assert draw_copies(64, 64, 64) == 2      # one 64 x 64 tile: two copies
    assert draw_copies(100, 64, 64) == 1     # two tiles: drawn as before
    assert draw_copies(128, 128, 64) == 1
    assert draw_copies(512, 512, 64) == 1
    assert draw_copies(12, 10, 8) == 2
    assert draw_copies(64, 64, 1) == 1       # never more copies than samples in a draw
    assert draw_copies(60, 60, 64, max_size=100) == 1  # the copies must fit a texture


def test_copies_give_the_image_of_one_draw(monkeypatch):
    p = prepare(CORNELL, resolution=(40, 24), feature_flags={"variance": True}, aovs=("albedo", "normal", "depth"))
    assert p.renderer.copies == 2
    try:
        # 9 passes: one draw of 9 samples, copy 0 takes 5 and copy 1 takes 4 (uneven shares).
        copies = draw(p.renderer, 9, seed=5)
    finally:
        p.renderer.release()
    monkeypatch.setattr("mcpt.gpu.render.draw_copies", lambda *args: 1)
    q = prepare(CORNELL, resolution=(40, 24), feature_flags={"variance": True}, aovs=("albedo", "normal", "depth"))
    assert q.renderer.copies == 1
    try:
        one = draw(q.renderer, 9, seed=5)
    finally:
        q.renderer.release()
    assert copies.dropped_samples == one.dropped_samples == 0
    assert not np.array_equal(copies.image, np.zeros_like(copies.image))
    np.testing.assert_allclose(copies.image, one.image, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(copies.variance, one.variance, rtol=1e-3, atol=1e-6)
    assert set(one.aovs) == set(copies.aovs) and one.aovs
    for name in one.aovs:
        np.testing.assert_allclose(copies.aovs[name], one.aovs[name], rtol=1e-5, atol=1e-6)

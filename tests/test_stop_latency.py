"""Issue #24 item 8: a stop (a signal, --time) acts inside a draw, not after it.

A draw (up to 2^22 paths, seconds on llvmpipe) is drawn in bands of rows (mcpt/gpu/bands.py) where
the render loop may stop; a stop between bands drops the draw in progress. Bands change no bit,
and a dropped draw leaves the passes before it, so resume stays bit-identical. Timings of the
stops are in bench/stop_latency.py, not here.
"""

from __future__ import annotations

import signal

import numpy as np
import pytest

from mcpt.farm.signals import StopSignals
from mcpt.gpu.bands import plan_bands

from .test_farm import folder, same_bits  # noqa: F401 (folder: a fixture)
from .test_render import FURNACE

SPP = 64
SIZE = (64, 48)  # 12 blocks of 16x16 in one column of llvmpipe tiles: parts hold pixels
PIXELS = SIZE[0] * SIZE[1]


class CountingVao:
    """The renderer's vertex array, counting the paths each GL draw takes (scissor x samples)
    and calling ``before`` first."""

    def __init__(self, renderer, before=None):
        self.r, self.vao, self.before = renderer, renderer.vao, before
        self.paths: list[int] = []

    def render(self, *args, **kw):
        if self.before is not None:
            self.before(len(self.paths))
        x0, y0, w, h = self.r.gl.ctx.scissor or (0, 0, self.r.width, self.r.height)
        part, parts = self.r.program["u_parts"].value[:2]
        y, x = np.mgrid[y0:y0 + h, x0:x0 + w]  # GL rows; a part's 16x16 blocks (fullscreen.vert)
        block = ((x >> 4) & 3) + 4 * ((y >> 4) & 3)
        covered = int((block % parts == part).sum()) if parts > 1 else w * h
        self.paths.append(covered * self.r.program["u_samples"].value)
        return self.vao.render(*args, **kw)

    def release(self):
        self.vao.release()


def _sums(r, spp, band_paths=None, chunk=64):
    """The read-backs of passes 0..spp-1, in whole draws (band_paths None) or in bands."""
    if band_paths is not None:
        r.band_paths, r.band_seconds = band_paths, 0.0  # these bands, whatever the speed
    drop = None if band_paths is None else (lambda summed, done: False)
    return list(r.passes(3, 0, spp, chunk=chunk, interrupt=lambda summed: False, drop_draw=drop))


def _same(a, b):
    return len(a) == len(b) and all(x[0] == y[0] and same_bits(x[1], y[1]) for x, y in zip(a, b))


def test_plan_bands_covers_the_tile_in_parts_of_at_most_the_paths_asked():
    """Strips of rows of 2^16 pixels at least, each in 2^k interleaved parts (glsl/fullscreen.vert)."""
    assert plan_bands((0, 0, 256, 256), 64, 0) == [(0, 0, 256, 256, 0, 1)]
    assert plan_bands((0, 0, 256, 256), 64, 1 << 22) == [(0, 0, 256, 256, 0, 1)]
    assert plan_bands((0, 0, 256, 256), 64, 1 << 18) == [(0, 0, 256, 256, k, 16) for k in range(16)]
    for tile, samples in (((0, 4, 250, 130), 64), ((0, 0, 512, 512), 16), ((0, 0, 4096, 4096), 4)):
        bands = plan_bands(tile, samples, 1 << 18)
        strips = sorted({b[:4] for b in bands}, key=lambda b: b[1])
        assert strips[0][1] == tile[1] and sum(b[3] for b in strips) == tile[3]
        assert all(a[1] + a[3] == b[1] for a, b in zip(strips, strips[1:]))
        assert all(b[2] * b[3] * samples <= b[5] * (1 << 18) for b in bands)


@pytest.mark.parametrize("aovs", [(), ("albedo", "normal", "depth", "variance")])
def test_bands_change_no_bit(folder, aovs):  # noqa: F811
    """Drawn in bands (72x40: 16 parts of one strip, or 4), every read-back (beauty, squares,
    AOVs) is the one of whole draws, bit for bit."""
    from mcpt.prepare import prepare

    p = prepare(folder / "scene.yaml", aovs=aovs, seed=3, resolution=(72, 40))
    r = p.renderer
    try:
        whole = _sums(r, 2 * SPP + 8)
        for band_paths in (72 * SPP, 72 * 8 * SPP + 7):
            vao = r.vao = CountingVao(r)
            banded = _sums(r, 2 * SPP + 8, band_paths)
            r.vao = vao.vao
            assert len(vao.paths) > 3 and sum(vao.paths) == 72 * 40 * (2 * SPP + 8)  # each pixel once
            assert _same(banded, whole)
    finally:
        r.release()


def test_strips_of_rows_change_no_bit(folder, monkeypatch):  # noqa: F811
    """Large images are cut into strips of rows first (here 16 rows of 72: 3 strips, 1-4 parts
    each): the same bits as whole draws."""
    from mcpt.gpu import bands
    from mcpt.prepare import prepare

    monkeypatch.setattr(bands, "STRIP_PIXELS", 72 * 16)
    p = prepare(folder / "scene.yaml", seed=3, resolution=(72, 40))
    r = p.renderer
    try:
        assert len({b[:4] for b in plan_bands((0, 0, 72, 40), SPP, 72 * 16 * SPP // 2)}) == 3
        assert _same(_sums(r, SPP + 8, 72 * 16 * SPP // 2), _sums(r, SPP + 8))
    finally:
        r.release()


def test_bands_change_no_bit_with_uploaded_numbers_in_tiles(folder, gl):  # noqa: F811
    """The independent sampler's tiles (random numbers per tile), each in bands."""
    from mcpt.gpu.features import for_world
    from mcpt.gpu.pack import pack
    from mcpt.gpu.render import Renderer
    from mcpt.scene import load_scene
    from mcpt.shapes.world import load_world

    world = load_world(load_scene(folder / "scene.yaml").with_overrides(resolution=SIZE))
    feats = for_world(world, sampler="independent")
    r = Renderer(gl, feats, pack(world, feats), max_random_per_tile=64 * feats.random_dims * 24)
    try:
        assert len(r.tiles) == 2
        assert _same(_sums(r, 12, 64 * 4, chunk=8), _sums(r, 12, chunk=8))
    finally:
        r.release()


def test_bands_change_no_bit_with_continued_paths():
    """Paths longer than llvmpipe's loop limit, continued by further draws, band by band."""
    from mcpt.prepare import prepare
    from mcpt.scene import load_scene

    scene = load_scene(FURNACE).with_overrides(resolution=(20, 18))
    p = prepare(scene, bounces=400, feature_flags={"russian_roulette": False})
    if not p.features.continues:  # pragma: no cover - a GPU without a loop limit
        pytest.skip("this driver has no loop limit")
    r = p.renderer
    try:
        assert _same(_sums(r, 4, 20 * 18), _sums(r, 4))
    finally:
        r.release()


def _signal_during_band(r, band):
    """A StopSignals that receives SIGTERM while band ``band`` of the first draw is drawn."""
    signals = StopSignals()

    def before(i):
        if i == band:
            signals.signum = signal.SIGTERM

    return signals, before


def test_a_signal_stops_inside_the_draw(folder):  # noqa: F811
    """SIGTERM while the first band of a 64-sample draw is drawn: no other band is drawn (the
    whole draw used to be), and the render stops with the passes before the draw: none."""
    from mcpt.prepare import prepare
    from mcpt.render import Options, run

    p = prepare(folder / "scene.yaml", seed=3, resolution=SIZE)
    r = p.renderer
    try:
        r.band_paths, r.band_seconds = PIXELS * SPP // 4, 0.0  # 4 parts
        signals, before = _signal_during_band(r, 0)
        vao = r.vao = CountingVao(r, before)
        out = run(p, Options(spp=4 * SPP), signals)
        r.vao = vao.vao
    finally:
        r.release()
    assert out.stopped_by == "signal" and out.interrupted == signal.SIGTERM
    assert out.result.spp == 0
    assert vao.paths == [PIXELS * SPP // 4]  # from the signal on: the band in progress


@pytest.fixture
def eight_a_draw(monkeypatch):
    """Draws of 8 samples at the folder's 12x10 pixels: draws end inside a read-back chunk."""
    from mcpt.gpu import features

    monkeypatch.setattr(features, "PATHS_PER_DRAW", PIXELS * 8)


def test_a_draw_dropped_inside_a_chunk_resumes_bit_identically(folder, eight_a_draw):  # noqa: F811
    """8 samples a draw: a signal in the second part of the third draw (passes 16..23) keeps
    passes 0..15 exactly as the target held them; the checkpoint resumes to the bits of one
    uninterrupted render."""
    from mcpt.prepare import prepare
    from mcpt.render import Options, run

    p = prepare(folder / "scene.yaml", seed=3, resolution=SIZE)
    r = p.renderer
    try:
        assert r.samples_per_draw == 8
        r.band_paths, r.band_seconds = PIXELS * 8 // 4, 0.0  # 4 parts a draw
        signals, before = _signal_during_band(r, 2 * 4 + 1)
        r.vao = CountingVao(r, before)
        out = run(p, Options(["a.exr"], spp=SPP, checkpoint=1000.0), signals)
        r.vao = r.vao.vao
        assert (out.stopped_by, out.result.spp) == ("signal", 16)
        resumed = run(p, Options(["a.exr"], spp=SPP, resume=True, checkpoint=1000.0))
        whole = run(p, Options(["b.exr"], spp=SPP))
    finally:
        r.release()
    assert resumed.resumed_from == 16 and resumed.result.spp == SPP
    assert same_bits(resumed.result.image, whole.result.image)


def test_the_budget_drops_a_draw_that_would_end_past_its_overrun(monkeypatch):
    """--time T may end by T + max(10 %, 1 s) (issue #24 item 8); a draw foreseen (from its
    bands after the first) to end past T + half of that is dropped, one that fits goes on."""
    from mcpt.farm import control as control_mod
    from mcpt.farm.control import Control, overrun
    from mcpt.render import Options

    assert overrun(2.0) == 1.0 and overrun(100.0) == 10.0
    clock = [0.0]
    monkeypatch.setattr(control_mod.time, "perf_counter", lambda: clock[0])
    c = Control(Options(["x.exr"], time_budget=10.0, started=0.0), StopSignals(), spp=1000,
                samples_per_draw=64)
    c.draw_started = 1.0
    for now, done in ((3.0, 0.25), (5.0, 0.5), (7.0, 0.75)):  # first band 2 s (a compile), then 2 s a band
        clock[0] = now
        assert not c.drop_draw(0, done) and c.stop is None
    c.draw_started = 8.0  # the next draw: its bands slow down (4 s a band)
    clock[0] = 9.0
    assert not c.drop_draw(64, 0.25)
    clock[0] = 13.0
    assert c.drop_draw(64, 0.5) and c.stop == "time"  # would end at 21 s


def test_a_budget_that_cannot_hold_the_first_draw_writes_nothing(folder):  # noqa: F811
    """A first draw cut by --time leaves no pass: refused in one line (exit 2), nothing written
    (it used to run the whole draw past the budget)."""
    import time

    from mcpt.prepare import prepare
    from mcpt.render import BudgetError, Options, run

    p = prepare(folder / "scene.yaml", seed=3, resolution=SIZE)
    r = p.renderer
    try:
        r.band_paths, r.band_seconds = PIXELS * SPP // 4, 0.0
        with pytest.raises(BudgetError, match=r"--time 1: the first draw would end at about"):
            run(p, Options(["a.exr"], spp=4 * SPP, time_budget=1.0, started=time.perf_counter() - 50))
    finally:
        r.release()
    assert not (folder / "a.exr").exists()

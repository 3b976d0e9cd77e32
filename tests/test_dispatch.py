"""The compute dispatch (MCPT_DISPATCH=compute, issue #23): glsl/pathtrace.frag run as a compute
shader adds its outputs into the accumulation targets with imageLoad + imageStore, the same
float32 adds in the same order as the fragment path's blending: the same bits, here on llvmpipe,
for every output (beauty, squares, AOVs, alpha), both samplers, continued paths and bands.
The wavefront dispatch (MCPT_DISPATCH=wavefront: shade and trace kernels, rays regrouped between
them) traces every ray and adds every sample as the fragment path does: the same bits too."""

from __future__ import annotations

import numpy as np
import pytest

from mcpt.api import Options, prepare, run
from mcpt.gpu.bands import plan_strips
from mcpt.gpu.features import Features
from mcpt.gpu.options import DispatchError, dispatch_flags

from .conftest import ROOT
from .test_farm import folder, invoke, same_bits  # noqa: F401 (folder: a fixture)
from .test_render import CORNELL, FURNACE
from .test_stop_latency import _same, _sums


def _render(monkeypatch, mode, scene, spp, **kw):
    monkeypatch.setenv("MCPT_DISPATCH", mode)
    p = prepare(scene, cache=False, **kw)
    try:
        assert p.features.defines()["MCPT_COMPUTE"] == int(mode != "fragment")
        assert p.features.defines()["MCPT_WAVE"] == int(mode == "wavefront")
        assert (p.renderer.vao is None) == (mode != "fragment")
        return run(p, Options(spp=spp, seed=5)).result
    finally:
        p.renderer.release()


def _same_result(a, b):
    assert same_bits(a.image, b.image) and a.dropped_samples == b.dropped_samples
    for x, y in ((a.variance, b.variance), (a.alpha, b.alpha)):
        assert (x is None) == (y is None) and (x is None or same_bits(x, y))
    assert sorted(a.aovs) == sorted(b.aovs)
    assert all(same_bits(np.asarray(a.aovs[k]), np.asarray(b.aovs[k])) for k in a.aovs)


@pytest.mark.parametrize("sampler, aovs", [("sobol", ()), ("independent", ("albedo", "normal", "depth", "variance"))])
def test_compute_and_fragment_dispatch_give_the_same_bits(monkeypatch, sampler, aovs):
    kw = dict(resolution=(72, 40), sampler=sampler, aovs=aovs)
    # 70 passes at 64 a draw: two draws and two read-backs, the targets cleared between them
    frag = _render(monkeypatch, "fragment", CORNELL, 70, **kw)
    comp = _render(monkeypatch, "compute", CORNELL, 70, **kw)
    assert frag.image.mean() > 0.01
    _same_result(frag, comp)


def test_continued_paths_and_a_transparent_film_give_the_same_bits(monkeypatch):
    """The albedo-0.999 furnace at 400 bounces: paths outlast llvmpipe's loop budget and are
    stored and continued (mcpt/gpu/path_state.py, images 0-3 beside the targets' 4-7); a
    transparent film adds the alpha target."""
    kw = dict(resolution=(24, 16), bounces=400, overrides=("materials.furnace.albedo=[0.999,0.999,0.999]",
                                                            "render.transparent=true"))
    frag = _render(monkeypatch, "fragment", FURNACE, 2, **kw)
    comp = _render(monkeypatch, "compute", FURNACE, 2, **kw)
    assert frag.setup["continuation_draws"] > 0 and frag.alpha is not None
    assert comp.setup["continuation_draws"] == frag.setup["continuation_draws"]
    _same_result(frag, comp)


def test_plan_strips_covers_the_tile_in_rectangles_of_at_most_the_paths_asked():
    assert plan_strips((0, 0, 256, 256), 64, 0) == [(0, 0, 256, 256, 0, 1)]
    assert plan_strips((0, 0, 256, 256), 64, 1 << 22) == [(0, 0, 256, 256, 0, 1)]
    for tile, samples, paths in (((0, 4, 250, 130), 64, 1 << 18), ((0, 0, 512, 512), 16, 1 << 18),
                                 ((3, 0, 100, 7), 64, 10)):  # 10 paths: one row a strip, more than asked
        strips = plan_strips(tile, samples, paths)
        assert all(s[0] == tile[0] and s[2] == tile[2] and s[4:] == (0, 1) for s in strips)
        assert strips[0][1] == tile[1] and sum(s[3] for s in strips) == tile[3]
        assert all(a[1] + a[3] == b[1] for a, b in zip(strips, strips[1:]))
        assert all(s[2] * s[3] * samples <= max(paths, s[2] * samples) for s in strips)


def test_strips_of_a_compute_dispatch_change_no_bit(folder, monkeypatch):  # noqa: F811
    """Drawn in strips (a stop may act between them, issue #24 item 8): every read-back is the
    one of whole dispatches, bit for bit."""
    monkeypatch.setenv("MCPT_DISPATCH", "compute")
    p = prepare(folder / "scene.yaml", seed=3, resolution=(72, 40))
    r = p.renderer
    try:
        whole = _sums(r, 72)
        assert len(plan_strips((0, 0, 72, 40), 64, 72 * 64 * 3)) == 14
        assert _same(_sums(r, 72, 72 * 64 * 3), whole)
    finally:
        r.release()


def test_the_fragment_dispatch_compiles_none_of_it():
    d = Features.of(bounces=2).defines()
    assert d["MCPT_COMPUTE"] == 0 and d["MCPT_WAVE"] == 0
    assert dispatch_flags({}) == {"compute": False, "wavefront": False}
    assert dispatch_flags({"MCPT_DISPATCH": " Compute "}) == {"compute": True, "wavefront": False}
    assert dispatch_flags({"MCPT_DISPATCH": "wavefront"}) == {"compute": True, "wavefront": True}
    with pytest.raises(DispatchError, match="MCPT_DISPATCH='vulkan': choose one of fragment, compute, wavefront"):
        dispatch_flags({"MCPT_DISPATCH": "vulkan"})


@pytest.mark.parametrize("scene, kw", [
    (CORNELL, dict(resolution=(72, 40), spp=70)),  # two draws, two read-backs; no BVH
    (ROOT / "scenes" / "bunny-metal.yaml", dict(resolution=(48, 32), spp=6)),  # BVH, rays queued in 2 classes
    (ROOT / "scenes" / "fog.yaml", dict(resolution=(40, 24), spp=4)),  # a medium: NEE in the shade kernel
    (CORNELL, dict(resolution=(40, 24), spp=3, sampler="independent", aovs=("variance",))),
])
def test_wavefront_and_fragment_dispatch_give_the_same_bits(monkeypatch, scene, kw):
    spp = kw.pop("spp")
    frag = _render(monkeypatch, "fragment", scene, spp, **kw)
    wave = _render(monkeypatch, "wavefront", scene, spp, **kw)
    assert frag.image.mean() > 0.001
    _same_result(frag, wave)


def test_wavefront_lays_many_groups_out_in_rows(monkeypatch):
    """More work groups than a row holds (GL guarantees 65535 an axis; 4096x4096 pixels need
    262144 of 64): rows of 3 groups here, the same bits."""
    from mcpt.gpu import wavefront

    frag = _render(monkeypatch, "fragment", CORNELL, 3, resolution=(40, 24))
    monkeypatch.setattr(wavefront, "ROW_GROUPS", 3)
    assert -(-40 * 24 // wavefront.GROUP) > 3 * wavefront.ROW_GROUPS  # the first shade: 5 rows
    wave = _render(monkeypatch, "wavefront", CORNELL, 3, resolution=(40, 24))
    assert frag.image.mean() > 0.01 and same_bits(frag.image, wave.image)
    _same_result(frag, wave)


def test_wavefront_follows_long_paths_without_continuation(monkeypatch):
    """The albedo-0.999 furnace at 400 bounces: the fragment path stores and continues its paths
    across draws (adding each sample in pieces); the wavefront runs one bounce a kernel and needs
    none, so its sums round differently but hold the same samples."""
    kw = dict(resolution=(24, 16), bounces=400, overrides=("materials.furnace.albedo=[0.999,0.999,0.999]",))
    frag = _render(monkeypatch, "fragment", FURNACE, 2, **kw)
    wave = _render(monkeypatch, "wavefront", FURNACE, 2, **kw)
    assert frag.setup["continuation_draws"] > 0 and "continuation_draws" not in wave.setup
    assert wave.setup["wavefront_steps"] >= 400  # a kernel pair a bounce
    assert wave.dropped_samples == frag.dropped_samples
    np.testing.assert_allclose(wave.image, frag.image, rtol=1e-5)


@pytest.mark.parametrize("args, what", [(("--aov", "albedo"), "the albedo, normal and depth AOVs"),
                                        (("-D", "render.transparent=true"), "a transparent film")])
def test_wavefront_refuses_what_it_cannot_render_in_one_line(folder, monkeypatch, args, what):  # noqa: F811
    monkeypatch.setenv("MCPT_DISPATCH", "wavefront")
    r = invoke("scene.yaml", "--spp", "1", *args, "-o", "x.exr")
    assert r.exit_code == 2 and f"MCPT_DISPATCH=wavefront cannot render {what}" in r.output
    assert len(r.output.strip().splitlines()) == 1 and not (folder / "x.exr").exists()


def test_an_unknown_dispatch_is_one_line_and_exit_2(folder, monkeypatch):  # noqa: F811
    monkeypatch.setenv("MCPT_DISPATCH", "vulkan")
    r = invoke("scene.yaml", "--spp", "1", "-o", "x.exr")
    assert r.exit_code == 2 and "MCPT_DISPATCH='vulkan'" in r.output
    assert len(r.output.strip().splitlines()) == 1 and not (folder / "x.exr").exists()

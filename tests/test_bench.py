"""bench/: the pure parts (fits, thresholds, metrics, records) and tiny end-to-end sweeps (32x32)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from mcpt.bench import common, mitsuba, peer, peer_run, plots, scenes, suite, sweeps

from .conftest import CORNELL_REF, ROOT

# ------------------------------------------------------------------------------------------------
# Pure parts
# ------------------------------------------------------------------------------------------------


def test_fit_power_recovers_an_exact_power_law():
    x = np.array([1, 2, 4, 8, 16], float)
    f = common.fit_power(x, 0.3 * x**-1.0)
    assert f.slope == pytest.approx(-1.0)
    assert 10**f.log10_c == pytest.approx(0.3)
    assert f.r2 == pytest.approx(1.0)
    assert f.predict(32.0) == pytest.approx(0.3 / 32)
    assert f.solve(0.003) == pytest.approx(100.0)


def test_fit_power_ignores_nonpositive_points_and_needs_two():
    f = common.fit_power([0, 1, 10], [5, 1, 0.01])
    assert f.n == 2 and f.slope == pytest.approx(-2.0)
    with pytest.raises(ValueError):
        common.fit_power([1, 2], [1, 0])


def test_fit_power_that_does_not_fall_never_reaches_a_threshold():
    f = common.fit_power([1, 2, 4], [1, 1.5, 2])
    assert f.slope > 0 and f.solve(0.1) is None


def test_time_to_threshold_interpolates_inside_the_range():
    t, e = [1.0, 2.0, 4.0], [1.0, 0.5, 0.25]
    r = common.time_to_threshold(t, e, 0.3)
    assert r["method"] == "interpolated"
    assert r["seconds"] == pytest.approx(1 / 0.3)  # exact on a 1/t law
    # order of the input does not matter
    assert common.time_to_threshold(t[::-1], e[::-1], 0.3)["seconds"] == pytest.approx(1 / 0.3)


def test_time_to_threshold_extrapolates_along_the_fit_outside_the_range():
    t, e = [1.0, 2.0, 4.0], [1.0, 0.5, 0.25]
    r = common.time_to_threshold(t, e, 0.01)
    assert r["method"] == "extrapolated" and r["seconds"] == pytest.approx(100.0)
    r = common.time_to_threshold([1, 2], [1, 2], 0.5)
    assert r["seconds"] is None and r["method"] == "not reached"


def test_metrics_and_exact_downsampling():
    ref = np.full((4, 4, 3), 0.1, np.float32)
    x = ref + 0.1
    assert common.rmse(x, ref) == pytest.approx(0.1)
    assert common.mae(x, ref) == pytest.approx(0.1)
    assert common.relmse(x, ref) == pytest.approx(0.01 / (0.01 + 0.01))
    big = np.arange(8 * 8 * 3, dtype=np.float32).reshape(8, 8, 3)
    small = common.downsample(big, 2, 2)
    assert small.shape == (2, 2, 3)
    assert small[0, 0, 0] == pytest.approx(big[:4, :4, 0].mean())
    assert small.mean() == pytest.approx(big.mean())
    with pytest.raises(ValueError):
        common.downsample(big, 3, 3)


def test_converges_compares_the_last_two_steps():
    assert common.converges([1.0, 1.5, 1.7, 1.75])["converges"]
    assert not common.converges([1.0, 1.1, 1.3])["converges"]


def test_records_are_plain_json_with_meta(tmp_path):
    meta = common.run_meta({"renderer": "test"}, argv=["x"])
    p = common.write_records(tmp_path, "demo", meta, {"spp": np.int64(4)},
                             [{"seconds": np.float32(1.5), "bad": float("nan"), "arr": np.arange(2)}],
                             {"ok": True})
    d = json.loads(p.read_text())
    assert d["sweep"] == "demo" and d["settings"]["spp"] == 4
    assert d["records"][0] == {"seconds": 1.5, "bad": None, "arr": [0, 1]}
    assert d["meta"]["gl"]["renderer"] == "test" and "revision" in d["meta"]["git"]
    assert not list(tmp_path.glob("*.tmp"))


def test_sweep_names_resolve_with_aliases():
    assert suite.resolve(None) == list(suite.ALL)
    assert "peer" not in suite.ALL and suite.resolve(["peer"]) == ["peer"]   # opt-in: it runs Mitsuba
    assert suite.resolve(["spec,tris", "error"]) == ["throughput", "triangles", "error"]
    with pytest.raises(ValueError, match="unknown sweep"):
        suite.resolve(["nope"])


def test_scene_builders_write_valid_yaml(tmp_path):
    from mcpt.scene import load_scene

    p = scenes.write(scenes.cornell(boxes=False), tmp_path)
    assert len(load_scene(p).meshes) == 4
    p = scenes.write(scenes.with_sphere(1, tmp_path / "cache"), tmp_path)
    assert load_scene(p).meshes[0].transform.scale is not None


# ------------------------------------------------------------------------------------------------
# Tiny end-to-end sweeps (GL)
# ------------------------------------------------------------------------------------------------


def _tiny(tmp_path, **kw) -> sweeps.Config:
    base = dict(out=tmp_path, bounces=(1, 2, 4), bounce_resolution=(32, 32), bounce_spp=8,
                tri_resolution=(32, 32), tri_spp=1, brute_cap_seconds=30.0,
                tri_ladder=tuple(scenes.TRIANGLE_LADDER[:3]), err_resolution=(32, 32),
                err_spp=(1, 4, 16, 64), self_reference_spp=256, tp_resolution=(32, 32), tp_spp=1,
                tp_repeats=1, tp_scenes=("cornell",))
    base.update(kw)
    return sweeps.config(True, **base)


def test_error_sweep_end_to_end_is_deterministic(gl, tmp_path):
    cfg = _tiny(tmp_path)
    a = sweeps.error_sweep(cfg)
    b = sweeps.error_sweep(cfg)
    rel = [r["relmse"] for r in a["records"]]
    assert rel == [r["relmse"] for r in b["records"]]          # same seed, same error figures
    assert rel[-1] < rel[0] / 8                                 # 64x the samples: MSE falls
    assert [r["rmse"] for r in a["records"]] == [r["rmse"] for r in b["records"]]
    s = a["summary"]
    assert -1.6 < s["fit_relmse_vs_spp"]["slope"] < -0.5
    assert s["time_to_relmse"][0]["method"] in ("interpolated", "extrapolated")
    # brightness converges on the reference's
    m, ref = np.array(a["records"][-1]["mean_rgb"]), np.array(s["reference_mean_rgb"])
    assert np.all(np.abs(m - ref) / ref < 0.05)


def test_suite_writes_records_plots_and_report(gl, tmp_path):
    cfg = _tiny(tmp_path, brute_cap_seconds=0.0)
    res = suite.run(["bounces", "triangles", "throughput"], cfg, log=lambda m: None, argv=["test"])
    assert res["done"] == ["bounces", "triangles", "throughput"], res["failed"]
    for f in ("bounces.json", "bounces.png", "bounces-sheet.png", "triangles.json", "triangles.png",
              "throughput.json", "throughput.png", "REPORT.md"):
        assert (tmp_path / f).stat().st_size > 0, f
    b = common.read_records(tmp_path / "bounces.json")
    lum = [r["mean_luminance"] for r in b["records"]]
    assert lum[0] < lum[1] < lum[2]                             # more bounces, more light
    assert all(r["mean_luminance_stderr"] > 0 for r in b["records"])
    t = common.read_records(tmp_path / "triangles.json")
    brute = [r for r in t["records"] if r["accel"] == "brute"]
    assert brute[0]["status"] == "ok"                           # the first level always runs
    assert all(r["status"] == "capped" for r in brute[1:])      # a 0 s cap stops the rest
    assert t["summary"]["max_triangles_bvh"] >= 36
    tp = common.read_records(tmp_path / "throughput.json")
    ok = [r for r in tp["records"] if r["status"] == "ok"]
    assert ok and all(r["paths_per_second"] > 0 for r in ok)
    report = (tmp_path / "REPORT.md").read_text()
    assert "![bounces](bounces.png)" in report and "## Render time against triangle count" in report
    assert not math.isnan(tp["summary"]["scenes"]["cornell"]["paths_per_second"])


# ------------------------------------------------------------------------------------------------
# Side by side with Mitsuba 3 (issue #14)
# ------------------------------------------------------------------------------------------------


def _synthetic_peer_records():
    """Exact power laws, three rounds. mcpt: relMSE = 0.3/spp in 0.01 s a pass; Mitsuba:
    relMSE = 0.27/spp in 0.004 s a pass. Round 1 is 3x slower (load) and the rounds' errors are
    0.9x, 1.0x, 1.1x the law, so the median time and the mean error are the law's exactly."""
    recs = []
    for rend, k, dt in (("mcpt", 0.3, 0.01), ("mitsuba", 0.27, 0.004)):
        for rnd, (slow, err) in enumerate(((1.0, 0.9), (3.0, 1.0), (1.0, 1.1))):
            for spp in (4, 16, 64, 256):
                t = spp * dt * slow
                recs.append({"scene": "box", "renderer": rend, "sampler": "independent",
                             "label": rend, "round": rnd, "spp": spp, "seconds": t, "cpu_seconds": 2 * t,
                             "relmse": err * k / spp, "rmse": 0.0, "paths_per_second": 100 * spp / t,
                             "paths_per_cpu_second": 100 * spp / (2 * t)})
    return recs


def test_peer_time_to_error_and_ratios_on_synthetic_data():
    s = peer.summarize(_synthetic_peer_records(), (1e-2, 1e-3))
    a, b = s["series"]["box/mcpt/independent"], s["series"]["box/mitsuba/independent"]
    assert a["seconds"] == pytest.approx([0.04, 0.16, 0.64, 2.56])          # medians over rounds
    assert a["relmse"] == pytest.approx([0.3 / n for n in (4, 16, 64, 256)])  # means over rounds
    assert a["paths_per_second"] == pytest.approx(100 / 0.01)
    # relMSE = 0.003 / t (mcpt), 0.00108 / t (Mitsuba)
    t1, t2 = a["time_to_relmse"]
    assert t1["method"] == "interpolated" and t1["seconds"] == pytest.approx(0.3)
    assert t2["method"] == "extrapolated" and t2["seconds"] == pytest.approx(3.0)  # 300 spp > 256
    assert [x["seconds"] for x in b["time_to_relmse"]] == pytest.approx([0.108, 1.08])
    assert a["fit_relmse_vs_seconds"]["slope"] == pytest.approx(-1.0)
    (r,) = s["ratios"]
    assert (r["mcpt"], r["mitsuba"], r["equal_spp"]) == ("independent", "independent", 256)
    assert r["paths_per_second_ratio"] == pytest.approx(0.4)
    assert r["time_to_relmse_ratio"] == pytest.approx([0.3 / 0.108, 3.0 / 1.08])
    assert r["cpu_time_to_relmse_ratio"] == pytest.approx([0.3 / 0.108, 3.0 / 1.08])
    assert r["relmse_ratio_at_equal_spp"] == pytest.approx(0.3 / 0.27)
    text = "\n".join(peer.summary_lines(s))
    assert "paths/s 0.4" in text and "time to 0.01 2.78" in text


def test_mitsuba_output_parsing_skips_warnings_and_reads_the_rounded_sample_count():
    out = ("\x1b[31m2026-11-22 WARN  [MultijitterSampler] Sample count rounded up to 42\n"
           '\x1b[0m{\n "spp": 37,\n "median_render_s": 0.5\n}\n')
    d = mitsuba.parse_output(out)
    assert d["spp"] == 37 and d["spp_actual"] == 42 and d["median_render_s"] == 0.5
    assert mitsuba.parse_output('{"spp": 16}')["spp_actual"] == 16
    with pytest.raises(mitsuba.MitsubaError):
        mitsuba.parse_output("LLVM ERROR: Cannot select")


@pytest.fixture
def peer_folder(tmp_path, monkeypatch):
    """A stand-in for the folder the peer bench reads ($MCPT_SHARED): Mitsuba's tool script (never
    run: the peer python is missing or fake) and a scene folder per peer scene. Every scene is the
    Cornell reference folder of tests/data: these tests are about how an absent or broken Mitsuba
    is reported and that mcpt's side still runs on each scene, not about the sphere scene."""
    root = tmp_path / "peer-shared"
    (root / "tools").mkdir(parents=True)
    (root / "tools" / "peer_mitsuba.py").write_text("raise SystemExit('a stand-in: never run')\n")
    (root / "scenes-ref").mkdir()
    for name in peer_run.PEER_SCENES:
        (root / "scenes-ref" / name).symlink_to(CORNELL_REF, target_is_directory=True)
    monkeypatch.setenv("MCPT_SHARED", str(root))
    return root


def test_mitsuba_absent_is_reported_not_raised(tmp_path, monkeypatch, peer_folder):
    monkeypatch.setenv("MCPT_PEER_PYTHON", str(tmp_path / "no-python"))
    a = mitsuba.available()
    assert not a.ok and "no-python" in a.reason


def test_ref_scene_folder_becomes_the_same_mcpt_scene(tmp_path):
    from mcpt.scene import load_scene

    sc = load_scene(scenes.write(peer_run.ref_scene_yaml(CORNELL_REF), tmp_path, "c"))
    ref = load_scene(ROOT / "scenes" / "cornell-box.yaml")
    assert len(sc.meshes) == len(ref.meshes) == 6
    assert sc.render.bounces == ref.render.bounces == 8
    assert sc.camera.vfov_deg == ref.camera.vfov_deg


def test_peer_sweep_without_mitsuba_runs_mcpt_and_says_so(gl, tmp_path, monkeypatch, peer_folder):
    monkeypatch.setenv("MCPT_PEER_PYTHON", str(tmp_path / "no-python"))
    lines = []
    pc = peer_run.peer_config(True, scenes=("cornell",), resolution=32, spp=(1, 4, 16), rounds=1)
    res = peer_run.peer_sweep(_tiny(tmp_path), lines.append, pc)
    skip = [ln for ln in lines if "Mitsuba 3 not available" in ln]
    assert len(skip) == 1 and "skipping its side" in skip[0]
    recs = res["records"]
    from mcpt.gpu.features import SAMPLERS

    assert {r["renderer"] for r in recs} == {"mcpt"} and len(recs) == 3 * len(SAMPLERS)
    assert all(r["relmse"] > 0 and r["paths_per_second"] > 0 for r in recs)
    assert res["summary"]["ratios"] == [] and not res["summary"]["mitsuba"]["available"]
    ser = res["summary"]["series"]["cornell/mcpt/independent"]
    assert ser["relmse"][2] < ser["relmse"][0] / 4                    # 16x the samples
    assert (tmp_path / "PEER.md").read_text().count("Mitsuba 3 not available") == 1
    assert plots.plot_peer(res, tmp_path)[0].stat().st_size > 0


def test_peer_renders_every_mcpt_sampler_with_that_sampler(monkeypatch, tmp_path):
    """Each mcpt side of the peer bench is prepared with its own sampler (mcpt.gpu.features)."""
    import mcpt.api

    seen = []

    def prepare(scene, *, sampler=None, feature_flags=None, **kw):
        seen.append((sampler, feature_flags))
        raise RuntimeError("stop here")

    monkeypatch.setattr(mcpt.api, "prepare", prepare)
    for s in ("sobol", "independent", "sobol@compute", "sobol@wavefront"):
        with pytest.raises(RuntimeError):
            peer_run._Mcpt(tmp_path / "x.yaml", type("C", (), {"seed": 0, "gl_backend": None})(), 8, s)
    assert seen == [("sobol", None), ("independent", None),
                    ("sobol", {"compute": True, "wavefront": False}),  # SAMPLER@DISPATCH (gpu_peer.py)
                    ("sobol", {"compute": True, "wavefront": True})]


def test_peer_sweep_with_a_broken_mitsuba_says_so_once(gl, tmp_path, monkeypatch, peer_folder):
    """A Mitsuba that imports but cannot render (llvm_ad_rgb on libLLVM 15 aborts): one line, no
    Mitsuba records, mcpt's side still measured."""
    fake = tmp_path / "fake-python"
    fake.write_text('#!/bin/sh\ncase "$1" in -c) echo 3.9.1;; '
                    '*) echo "LLVM ERROR: Cannot select: fminimum" >&2; exit 134;; esac\n')
    fake.chmod(0o755)
    monkeypatch.setenv("MCPT_PEER_PYTHON", str(fake))
    lines = []
    pc = peer_run.peer_config(True, resolution=32, spp=(1, 4), rounds=1)
    res = peer_run.peer_sweep(_tiny(tmp_path), lines.append, pc)
    bad = [ln for ln in lines if "Mitsuba" in ln and "skipping its side" in ln]
    assert len(bad) == 1 and "Cannot select" in bad[0]
    assert {r["renderer"] for r in res["records"]} == {"mcpt"}
    assert {r["scene"] for r in res["records"]} == {"cornell", "cornell-sphere-100k"}
    assert res["summary"]["mitsuba"]["available"] is False


def test_coherence_bound_changes_only_the_scramble_key(gl, tmp_path):
    """bench/coherence.py's side B differs from the shipped shaders by the Sobol' scramble's key
    alone (the pixel's 4x2 block): its lanes of a batch draw the same numbers, so its traversal
    loops use more of each batch, and its image is the same scene (means agree within noise)."""
    from mcpt.bench import coherence
    from mcpt.gpu import shader

    shipped = shader.glsl_dir()
    b = coherence.block_shaders(tmp_path)
    changed = [f.name for f in sorted(shipped.glob("*.glsl")) if f.read_text() != (b / f.name).read_text()]
    assert changed == ["sobol.glsl"] and coherence.PER_BLOCK in (b / "sobol.glsl").read_text()
    try:
        r = coherence.compare(ROOT / "scenes" / "bunny-metal.yaml", {"A": None, "B": b},
                              spp=4, rounds=2, resolution=(64, 48))
    finally:
        coherence._use(None)
    assert shader.glsl_dir() == shipped
    a, bb = r["A"], r["B"]
    assert a["paths_per_cpu_s"] > 0 and bb["paths_per_cpu_s"] > 0
    assert a["image_mean"] != bb["image_mean"]  # other numbers ...
    assert bb["image_mean"] == pytest.approx(a["image_mean"], rel=0.1)  # ... the same scene
    if a["lane_utilization"] is not None:  # the driver counts batches (GL_ARB_shader_ballot)
        assert bb["lane_utilization"] > a["lane_utilization"]


def test_ray_order_regroups_rays_without_changing_their_hits(gl):
    """bench/ray_order.py: each 8 consecutive rays of an order fill one 4x2 batch of the probe,
    and a ray's hit does not depend on where it is traced (so orders compare the same work)."""
    from mcpt.bench import ray_order
    from mcpt.scene import load_scene
    from mcpt.shapes.world import load_world

    order = np.arange(64)[::-1]
    slots = ray_order.batch_layout(order, 16)
    assert sorted(slots) == list(range(64))
    assert list(slots[[0, 1, 2, 3, 16, 17, 18, 19]]) == list(order[:8])  # batch 0: x 0-3, rows 0-1
    assert list(slots[[4, 5, 6, 7, 20, 21, 22, 23]]) == list(order[8:16])
    codes = ray_order.morton(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]), 1)
    assert list(codes) == [0, 1, 2, 3]

    scene = load_scene(ROOT / "scenes" / "bunny-metal.yaml")
    tracer = ray_order.Tracer(gl, load_world(scene), 32)
    o, d = ray_order.camera_rays(scene.camera, 32, 32)
    plain, _ = tracer.trace(o, d)
    assert (plain[:, 1] > 0).mean() > 0.5  # the box, the bunny (the open side misses)
    shuffled = ray_order.batch_layout(np.random.default_rng(0).permutation(len(o)), 32)
    moved, util = tracer.trace(o[shuffled], d[shuffled], counters=True)
    assert np.array_equal(moved, plain[shuffled])
    if util is not None:
        assert 0.0 < util <= 1.0


def test_dispatch_bench_renders_every_dispatch_to_the_same_bits(gl):
    from mcpt.bench import dispatch

    r = dispatch.compare(ROOT / "scenes" / "bunny-metal.yaml", ["fragment", "compute", "wavefront"],
                         spp=2, rounds=2, resolution=(24, 16))
    assert r["same_bits"] and r["paths"] == 2 * 2 * 24 * 16
    assert all(r["cpu_s"][m] > 0 and r["wall_s"][m] > 0 for m in ("fragment", "compute", "wavefront"))


def test_fetch_cost_reads_the_same_chain_through_both_buffer_kinds(gl):
    from mcpt.bench import fetch_cost

    r = fetch_cost.measure(4096, steps=8, size=32, rounds=1)  # raises if the two sums differ
    assert r["bytes"] == 4096 * 16
    assert r["tbo_ns_per_fetch"] > 0 and r["ssbo_ns_per_fetch"] > 0

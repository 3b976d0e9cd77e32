"""bench/: the pure parts (fits, thresholds, metrics, records) and tiny end-to-end sweeps (32x32)."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from mcpt.bench import common, scenes, suite, sweeps  # noqa: E402

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

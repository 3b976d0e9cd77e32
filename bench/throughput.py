"""The throughput sweep (``mcpt bench --only throughput``): paths/s of the scene's specialised
shader against the uber-shader (``--features all``), with set-up, compile and JIT seconds beside.
Timing conventions: bench/sweeps.py."""

from __future__ import annotations

import statistics

import numpy as np

from . import common, compile_probe, peer, scenes
from .sweeps import Config, _noop, _open, _render, _scene_path


def throughput_sweep(cfg: Config, log=_noop) -> dict:
    """paths/s at 256x256 and 8 bounces for the Cornell box and the bunny in the box, with the
    scene's specialised shader and with the uber-shader (``--features all``), interleaved so both
    see the same machine load; set-up and random-number seconds reported beside. A mode that
    fails to compile or upload is recorded with its error; the other is still measured."""
    w, h = cfg.tp_resolution
    builders = {"cornell": lambda: scenes.cornell(),
                "bunny": lambda: scenes.with_model("bunny", 0, cfg.cache)}
    modes = ("scene", "all")
    records = []
    summary: dict = {"scenes": {}}
    for name in cfg.tp_scenes:
        path = _scene_path(cfg, builders[name](), name)
        cold = {mode: compile_probe.run(path, mode, cfg.gl_backend) for mode in modes}
        sessions, failed = {}, {}
        for mode in modes:
            try:
                sessions[mode] = _open(path, cfg, resolution=(w, h), features_mode=mode,
                                       clear_shader_cache=True)
            except Exception as exc:  # e.g. an uber-shader feature the renderer lacks
                failed[mode] = f"{type(exc).__name__}: {exc}"
                log(f"{name:8s} {mode:5s}: FAILED {failed[mode]}")
        runs: dict = {m: [] for m in sessions}
        images: dict = {}
        try:
            for _ in range(cfg.tp_repeats):
                for mode, s in sessions.items():
                    r, m = _render(s, cfg.tp_spp, cfg.seed)
                    m["loadavg_1min"] = common.loadavg()
                    runs[mode].append(m)
                    images[mode] = r.image
        finally:
            for s in sessions.values():
                s.p.renderer.release()
        per = {}
        for mode in modes:
            if mode in failed:
                records.append({"scene": name, "features_mode": mode, "status": "failed",
                                "error": failed[mode], "cold_compile": cold[mode]})
                continue
            s, rs = sessions[mode], runs[mode]
            pps = statistics.median(r["paths_per_second"] for r in rs)
            rec = {"scene": name, "features_mode": mode, "status": "ok", "width": w, "height": h,
                   "bounces": 8, "seed": cfg.seed, "spp": cfg.tp_spp, "repeats": cfg.tp_repeats,
                   "paths_per_second": pps,
                   "render_seconds": statistics.median(r["render_seconds"] for r in rs),
                   "paths_per_cpu_second": statistics.median(r["paths_per_cpu_second"] for r in rs),
                   "random_fraction": statistics.median(r["random_fraction"] for r in rs),
                   "mean_rgb": rs[0]["mean_rgb"], "runs": rs, "setup": s.info,
                   "cold_compile": cold[mode]}
            records.append(rec)
            per[mode] = rec
            log(f"{name:8s} {mode:5s}: {pps / 1e6:.3f} Mpaths/s  cold compile "
                f"{_f(cold[mode].get('compile_seconds'))} s + JIT {_f(_jit(cold[mode]))} s  "
                f"upload {s.info['upload_bytes_total']:,d} B  random {rec['random_fraction']:.1%}")
        summary["scenes"][name] = _throughput_summary(per, failed, cold, images)
    summary["peer"] = peer.throughput_figures()
    return {"sweep": "throughput", "records": records, "summary": summary,
            "settings": {"resolution": [w, h], "spp": cfg.tp_spp, "repeats": cfg.tp_repeats,
                         "bounces": 8, "seed": cfg.seed, "scenes": list(cfg.tp_scenes)}}


def _throughput_summary(per: dict, failed: dict, cold: dict, images: dict) -> dict:
    def both(fn):
        return {m: (fn(per[m]) if m in per else None) for m in ("scene", "all")}

    any_rec = per.get("scene") or per.get("all") or {}
    out = {
        "triangles": any_rec.get("setup", {}).get("triangles"),
        "paths_per_second": per["scene"]["paths_per_second"] if "scene" in per else None,
        "paths_per_second_all": per["all"]["paths_per_second"] if "all" in per else None,
        "paths_per_cpu_second": both(lambda r: r["paths_per_cpu_second"]),
        # the CPU-second ratio is the steadier one when other work shares the cores
        "speedup_scene_vs_all_cpu": (per["scene"]["paths_per_cpu_second"] / per["all"]["paths_per_cpu_second"]
                                     if len(per) == 2 else None),
        "speedup_scene_vs_all": (per["scene"]["paths_per_second"] / per["all"]["paths_per_second"]
                                 if len(per) == 2 else None),
        "compile_seconds_warm": both(lambda r: r["setup"]["compile_seconds"]),
        "first_pass_seconds_warm": both(lambda r: r["setup"]["first_pass_seconds"]),
        "cold_compile_seconds": {m: cold[m].get("compile_seconds") for m in cold},
        "cold_jit_seconds": {m: _jit(cold[m]) for m in cold},
        "upload_bytes": both(lambda r: r["setup"]["upload_bytes_total"]),
        "upload_bytes_by_buffer": both(lambda r: r["setup"]["upload_bytes"]),
        "random_bytes_per_pass": both(lambda r: r["setup"]["random_bytes_per_pass"]),
        "setup_seconds": any_rec.get("setup", {}).get("setup_seconds"),
        "random_fraction": any_rec.get("random_fraction"),
        "failed": failed,
    }
    if len(per) == 2:
        sp, al = per["scene"], per["all"]
        out["features_differ"] = sp["setup"]["features"] != al["setup"]["features"]
        ms, ma = np.array(sp["mean_rgb"]), np.array(al["mean_rgb"])
        out["mean_rel_diff_scene_vs_all"] = [float(x) for x in (ms - ma) / np.maximum(ma, 1e-12)]
        out["relmse_scene_vs_all"] = common.relmse(images["scene"], images["all"])
    return out


def _jit(cold: dict) -> float | None:
    """llvmpipe's code generation at the first draw: first 16x16 pass minus the second."""
    if "first_pass_seconds" not in cold:
        return None
    return max(cold["first_pass_seconds"] - cold["second_pass_seconds"], 0.0)


def _f(x, fmt=".3f") -> str:
    return "?" if x is None else format(x, fmt)

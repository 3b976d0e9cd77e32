"""The Markdown report: every ``<sweep>.json`` found in the output folder, with its plots."""

from __future__ import annotations

from pathlib import Path

from . import common

ORDER = ("peer", "throughput", "error", "triangles", "bounces")


def _f(x, fmt=".3g", none="—"):
    if x is None:
        return none
    return format(x, fmt)


def _meta_line(meta: dict) -> str:
    g = meta.get("git", {})
    gl = meta.get("gl", {})
    return (f"_{meta.get('time_utc', '?')}, git {str(g.get('revision', '?'))[:10]}"
            f"{' (dirty tree)' if g.get('dirty') else ''}, {gl.get('renderer', '?')} "
            f"({gl.get('backend', '?')}), {meta.get('machine', {}).get('cpus', '?')} CPUs, "
            f"load {meta.get('loadavg_1min', '?')}_")


def section_throughput(d: dict) -> list[str]:
    sm, st = d["summary"], d["settings"]
    L = ["## Paths per second and shader specialisation", "", _meta_line(d["meta"]), "",
         f"{st['resolution'][0]}x{st['resolution'][1]}, 8 bounces, {st['spp']} spp, median of "
         f"{st['repeats']} run(s), scene and uber-shader runs interleaved. Set-up is excluded from "
         "paths/s and listed apart. Compile figures come from a fresh process with Mesa's disk "
         "shader cache off (bench/compile_probe.py); in a warm process both are near zero.", "",
         "| scene | triangles | Mpaths/s specialised | Mpaths/s `--features all` | ratio "
         "| Mpaths/CPU-s (spec / all) | ratio (CPU-s) | compile s, cold (spec / all) "
         "| first-draw JIT s, cold (spec / all) | upload bytes (spec / all) | set-up s "
         "| random numbers, share of render |",
         "|---|---:|---:|---:|---:|---|---:|---|---|---|---:|---:|"]
    M = 1e-6
    for name, s in sm["scenes"].items():
        pps, ppa = s.get("paths_per_second"), s.get("paths_per_second_all")
        cc, cj, ub = s["cold_compile_seconds"], s["cold_jit_seconds"], s["upload_bytes"]
        cpu = s.get("paths_per_cpu_second") or {}
        L.append(f"| {name} | {_f(s['triangles'], ',d')} | {_f(pps and pps * M, '.3f')} | "
                 f"{_f(ppa and ppa * M, '.3f', 'failed')} | {_f(s.get('speedup_scene_vs_all'), '.2f')}x | "
                 f"{_f(cpu.get('scene') and cpu['scene'] * M, '.3f')} / "
                 f"{_f(cpu.get('all') and cpu['all'] * M, '.3f')} | "
                 f"{_f(s.get('speedup_scene_vs_all_cpu'), '.2f')}x | "
                 f"{_f(cc.get('scene'), '.3f')} / {_f(cc.get('all'), '.3f')} | "
                 f"{_f(cj.get('scene'), '.3f')} / {_f(cj.get('all'), '.3f')} | "
                 f"{_f(ub.get('scene'), ',d')} / {_f(ub.get('all'), ',d')} | "
                 f"{_f(s.get('setup_seconds'), '.2f')} | {_f(s.get('random_fraction'), '.1%')} |")
    for name, s in sm["scenes"].items():
        for mode, err in (s.get("failed") or {}).items():
            L.append(f"\n- {name}, `--features {mode}`: **failed**: `{err}`")
        if s.get("features_differ") is False:
            L.append(f"\n- {name}: the scene's features equal the uber-shader's (nothing to leave "
                     "out), so both columns run the same program: their ratio is machine noise.")
        if "relmse_scene_vs_all" in s:
            L.append(f"\n- {name}: same seed, specialised vs uber-shader image: relMSE "
                     f"{s['relmse_scene_vs_all']:.2e}, mean difference "
                     + ", ".join(f"{c} {100 * d:+.3f} %" for c, d in zip("RGB", s["mean_rel_diff_scene_vs_all"])))
    pk = sm.get("peer", {})
    if pk:
        L += ["", "Mitsuba 3 on the same Cornell box, same machine kind (peer study): " + "; ".join(
            f"{d['label']} {d['paths_per_second'] / 1e6:.2f} Mpaths/s, "
            f"{_f(d.get('paths_per_cpu_second') and d['paths_per_cpu_second'] / 1e6, '.2f')} Mpaths/CPU-s "
            f"({d['spp']} spp)" for d in pk.values()) + "."]
    L += ["", "![throughput](throughput.png)", ""]
    return L


def section_error(d: dict) -> list[str]:
    sm, st, recs = d["summary"], d["settings"], d["records"]
    fit = sm.get("fit_relmse_vs_seconds", {})
    L = ["## Error against run time", "", _meta_line(d["meta"]), "",
         f"Cornell box {st['resolution'][0]}x{st['resolution'][1]}, 8 bounces, seed {st['seed']}, "
         f"each spp a separate render; reference: {sm['reference']['note']}. Time = render "
         "seconds (set-up excluded).", "",
         "| spp | render s | Mpaths/s | RMSE | relMSE | MAE | relMSE·spp |",
         "|---:|---:|---:|---:|---:|---:|---:|"]
    for r in recs:
        L.append(f"| {r['spp']} | {r['render_seconds']:.3f} | {r['paths_per_second'] / 1e6:.3f} | "
                 f"{r['rmse']:.4g} | {r['relmse']:.4g} | {r['mae']:.4g} | {r['relmse_x_spp']:.3f} |")
    if fit:
        L += ["", f"- log-log fit relMSE ∝ seconds^k: **k = {fit['slope']:.3f}** (R² {fit['r2']:.4f}); "
                  f"against spp: k = {sm['fit_relmse_vs_spp']['slope']:.3f}. "
                  f"At least as fast as 1/spp (k ≤ −0.85): {'yes' if sm.get('slope_at_least_minus_1') else 'NO'}."]
    for tt, ts in zip(sm.get("time_to_relmse", []), sm.get("spp_to_relmse", [])):
        L.append(f"- time to relMSE {tt['threshold']:g}: **{_f(tt['seconds'], '.3g')} s** "
                 f"({tt['method']}; ≈ {_f(ts['seconds'], '.3g')} spp)")
    if recs and all("denoised_relmse" in r for r in recs):
        L += ["", "Denoised with OIDN (mcpt[denoise]; albedo and normal AOVs) — **biased**: the error "
                  "no longer falls as 1/spp and stalls at the filter's bias.", "",
              "| spp | render + denoise s | relMSE raw | relMSE denoised (biased) |", "|---:|---:|---:|---:|"]
        L += [f"| {r['spp']} | {r['render_seconds'] + r['denoise_seconds']:.3f} | {r['relmse']:.4g} | "
              f"{r['denoised_relmse']:.4g} |" for r in recs]
    mean = recs[-1]["mean_rgb"] if recs else None
    if mean:
        ref = sm["reference_mean_rgb"]
        L.append("- image mean at the highest spp against the reference's: " + ", ".join(
            f"{c} {100 * (m - r) / r:+.2f} %" for c, m, r in zip("RGB", mean, ref)))
    pk = sm.get("peer", {})
    if pk:
        L += ["", "| renderer | relMSE ∝ t^k | wall s to relMSE 1e-2 | wall s to relMSE 1e-3 "
                  "| CPU s to 1e-2 | CPU s to 1e-3 |", "|---|---:|---:|---:|---:|---:|"]

        def cells(tt):
            return " | ".join(f"{_f(x['seconds'], '.3g')} ({x['method'][:6]}.)" for x in tt)

        tt, ct = sm.get("time_to_relmse", []), sm.get("cpu_time_to_relmse", [])
        if tt and fit:
            L.append(f"| **mcpt** (this run) | {fit['slope']:.3f} | {cells(tt)} | {cells(ct)} |")
        for p in pk.values():
            L.append(f"| {p['label']} (peer) | {p['fit_relmse_vs_seconds']['slope']:.3f} | "
                     f"{cells(p['time_to_relmse'])} | {cells(p.get('cpu_time_to_relmse', []))} |")
        L += ["", "CPU seconds count both cores' work (llvmpipe's threads included): on a shared "
                  "machine they move much less than wall seconds."]
    L += ["", "![error vs time](error.png)", ""]
    return L


def section_triangles(d: dict) -> list[str]:
    sm, st, recs = d["summary"], d["settings"], d["records"]
    w, h = st["resolution"]
    L = ["## Render time against triangle count", "", _meta_line(d["meta"]), "",
         f"{w}x{h}, {st['spp']} spp, 8 bounces; models from ../shared/models in the Cornell box "
         "(boxes removed), the bunny midpoint-subdivided (same surface, 4x/16x triangles). "
         f"Brute force is skipped once its projected time passes {st['brute_cap_seconds']:.0f} s.", "",
         "| scene | triangles | BVH ms/pass | brute ms/pass | BVH build s | mesh load s | TBO bytes "
         "| BVH nodes / depth |",
         "|---|---:|---:|---:|---:|---:|---:|---|"]
    brute = {r["triangles"]: r for r in recs if r["accel"] == "brute"}
    for r in (x for x in recs if x["accel"] == "bvh"):
        b = brute.get(r["triangles"])
        bs = ("capped" + (f" (≈{b['projected_seconds']:.0f} s)" if b.get("projected_seconds") else "")
              if b and b["status"] == "capped" else f"{b['seconds_per_pass'] * 1e3:.1f}" if b else "—")
        s = r["setup"]
        L.append(f"| {r['scene']} | {r['triangles']:,d} | {r['seconds_per_pass'] * 1e3:.1f} | {bs} | "
                 f"{s['bvh_build_seconds']:.3f} | {s['load_seconds']:.2f} | {s['upload_bytes_total']:,d} | "
                 f"{s['bvh_nodes']:,d} / {s['bvh_depth']} |")
    L.append("")
    L.append(f"- largest scene with the BVH: **{sm['max_triangles_bvh']:,d} triangles**; brute force "
             f"measured up to {sm['max_triangles_brute']:,d}, capped from {_f(sm.get('brute_capped_from'), ',d')}.")
    if "bvh_log_fit" in sm:
        f = sm["bvh_log_fit"]
        L.append(f"- BVH time per pass ≈ {f['a'] * 1e3:.1f} ms + {f['b_per_decade'] * 1e3:.1f} ms per "
                 f"decade of triangles (R² {f['r2']:.2f}); {sm['bvh_triangle_ratio_max_vs_min']:,.0f}x the "
                 f"triangles cost {sm['bvh_time_ratio_max_vs_min']:.1f}x the time.")
    if "bunny_subdivision" in sm:
        b = sm["bunny_subdivision"]
        L.append(f"- same bunny, {b['triangle_ratio']:.0f}x the triangles: {b['time_ratio']:.2f}x the time per pass.")
    if sm.get("brute_faster_up_to"):
        L.append(f"- brute force beats the BVH up to {sm['brute_faster_up_to']:,d} triangles in this sweep.")
    if "bvh_build_fit" in sm:
        L.append(f"- BVH build seconds ∝ N^{sm['bvh_build_fit']['slope']:.2f} (N ≥ 1000).")
    L += ["", "![triangles](triangles.png)", ""]
    return L


def section_bounces(d: dict) -> list[str]:
    sm, st, recs = d["summary"], d["settings"], d["records"]
    L = ["## Bounce sweep", "", _meta_line(d["meta"]), "",
         f"Cornell box {st['resolution'][0]}x{st['resolution'][1]}, {st['spp']} spp, seed {st['seed']}.", "",
         "| bounces | mean R | mean G | mean B | mean luminance ± std. error | step ± std. error "
         "| render s | Mpaths/s |",
         "|---:|---:|---:|---:|---:|---:|---:|---:|"]
    steps = [None] + sm["steps"]
    ses = [None] + sm.get("steps_stderr", [None] * len(sm["steps"]))
    for r, s, se in zip(recs, steps, ses):
        step = "" if s is None else f"{s:+.5f}" + (f" ± {se:.5f}" if se is not None else "")
        L.append(f"| {r['bounces']} | {r['mean_rgb'][0]:.5f} | {r['mean_rgb'][1]:.5f} | {r['mean_rgb'][2]:.5f} | "
                 f"{r['mean_luminance']:.5f} ± {_f(r.get('mean_luminance_stderr'), '.5f')} | {step} | "
                 f"{r['render_seconds']:.2f} | {r['paths_per_second'] / 1e6:.3f} |")
    L += ["", f"- converges (last step smaller than the one before): **{'yes' if sm['converges'] else 'NO'}**",
          "", "![bounces](bounces.png)", "", "![contact sheet](bounces-sheet.png)", ""]
    return L


def section_peer(d: dict) -> list[str]:
    from .peer import report_lines

    return report_lines(d["summary"], d["settings"]) + ["", "![peer](peer.png)", ""]


SECTIONS = {"throughput": section_throughput, "error": section_error,
            "triangles": section_triangles, "bounces": section_bounces, "peer": section_peer}


def write_report(out: Path, quick: bool | None = None) -> Path:
    out = Path(out)
    L = ["# mcpt benchmark report", "",
         "Written by `python -m mcpt.bench.run` / `mcpt bench`; the numbers are in the JSON files "
         "beside this report (one per sweep). Mitsuba 3 figures come from the peer sweep of the same "
         "run where it ran (`--only peer`), else from ../shared/research (same kind of machine).", ""]
    for name in ORDER:
        p = out / f"{name}.json"
        if p.exists():
            d = common.read_records(p)
            L += SECTIONS[name](d)
    path = out / "REPORT.md"
    path.write_text("\n".join(L) + "\n")
    return path

"""Mitsuba 3 beside mcpt: its stored figures, and the pure side of the side-by-side run.

The first part reads Mitsuba's figures measured earlier on this kind of machine
(../shared/research/peer-mitsuba-data). The second turns the records of ``mcpt bench --only
peer`` (bench/peer_run.py: both renderers measured alternately in one run) into curves, times to
an error and mcpt / Mitsuba ratios; it touches no GL and runs no process.

The stored figures were measured by someone else (Mitsuba 3.9.1, 2 vCPU, same scenes and conventions, see
peer-mitsuba.md); we only read them, to put them beside ours. Times are the median wall seconds of
one ``mi.render`` call (set-up excluded), errors against the same reference.exr.
"""

from __future__ import annotations

import json
import statistics
from pathlib import Path

from . import common, scenes


def data_dir() -> Path:
    return scenes.shared_dir() / "research" / "peer-mitsuba-data"


def load(kind: str, variant: str = "llvm") -> dict | None:
    """``kind`` in spp, tris, bounces; ``variant`` llvm or scalar. None when the file is missing."""
    p = data_dir() / f"{kind}-{variant}.json"
    if not p.exists():
        return None
    return json.loads(p.read_text())


def error_figures(thresholds=(1e-2, 1e-3)) -> dict:
    """Per variant: the (seconds, spp, relMSE, RMSE) rows, the log-log fit and time to each
    threshold, computed with the same functions as ours."""
    out = {}
    for variant in ("llvm", "scalar"):
        d = load("spp", variant)
        if d is None:
            continue
        rows = d["rows"]
        t = [r["median_s"] for r in rows]
        rel = [r["relmse"] for r in rows]
        fit = common.fit_power(t, rel)
        out[variant] = {
            "label": f"Mitsuba {d.get('mitsuba', '3')} {d.get('variant', variant)}",
            "seconds": t, "spp": [r["spp"] for r in rows], "relmse": rel,
            "rmse": [r["rmse"] for r in rows],
            "paths_per_second": [r["paths_per_s"] for r in rows],
            "fit_relmse_vs_seconds": fit.as_dict(),
            "time_to_relmse": [common.time_to_threshold(t, rel, thr, fit) for thr in thresholds],
            "cpu_time_to_relmse": [common.time_to_threshold([r["median_cpu_s"] for r in rows], rel, thr)
                                   for thr in thresholds],
        }
    return out


def throughput_figures() -> dict:
    """Mitsuba's paths/s on the plain Cornell box (256x256, 8 bounces) at its largest spp."""
    out = {}
    for variant in ("llvm", "scalar"):
        d = load("spp", variant)
        if d is None:
            continue
        row = max(d["rows"], key=lambda r: r["spp"])
        out[variant] = {"label": f"Mitsuba {d.get('mitsuba', '3')} {d.get('variant', variant)}",
                        "scene": "cornell", "spp": row["spp"], "paths_per_second": row["paths_per_s"],
                        "paths_per_cpu_second": row.get("paths_per_cpu_s")}
    return out


def triangle_figures(variant: str = "llvm") -> dict | None:
    d = load("tris", variant)
    if d is None:
        return None
    rows = d["rows"]
    return {"label": f"Mitsuba {d.get('mitsuba', '3')} {d.get('variant', variant)} (256x256, 64 spp)",
            "triangles": [r["triangles"] for r in rows],
            "seconds_per_pass": [r["median_s"] / r["spp"] for r in rows],
            "paths_per_second": [r["paths_per_s"] for r in rows],
            "load_seconds": [r["t_load_s"] for r in rows]}


def bounce_figures(variant: str = "llvm") -> dict | None:
    d = load("bounces", variant)
    if d is None:
        return None
    rows = d["rows"]
    return {"label": f"Mitsuba {d.get('mitsuba', '3')} {d.get('variant', variant)} (256x256, 64 spp)",
            "bounces": [r["bounces"] for r in rows],
            "paths_per_second": [r["paths_per_s"] for r in rows]}


# ------------------------------------------------------------------------------------------------
# Pure: series, time to error, ratios (tests/test_bench.py checks these on synthetic records)
# ------------------------------------------------------------------------------------------------


def series(records: list[dict], thresholds=(1e-2, 1e-3)) -> dict:
    """One curve per (scene, renderer, sampler): per spp the median seconds over rounds and the
    mean relMSE over rounds; its power-law fit and the time to each threshold."""
    groups: dict = {}
    for r in records:
        groups.setdefault((r["scene"], r["renderer"], r["sampler"]), []).append(r)
    out: dict = {}
    for (scene, rend, samp), rs in groups.items():
        spps = sorted({r["spp"] for r in rs})
        by = {s: [r for r in rs if r["spp"] == s] for s in spps}
        t = [statistics.median(r["seconds"] for r in by[s]) for s in spps]
        cpu = [statistics.median(r["cpu_seconds"] for r in by[s]) for s in spps]
        rel = [statistics.fmean(r["relmse"] for r in by[s]) for s in spps]
        pps = [statistics.median(r["paths_per_second"] for r in by[s]) for s in spps]
        d = {"scene": scene, "renderer": rend, "sampler": samp, "label": rs[0]["label"],
             "spp": spps, "seconds": t, "cpu_seconds": cpu, "relmse": rel,
             "rmse": [statistics.fmean(r["rmse"] for r in by[s]) for s in spps],
             "paths_per_second_by_spp": pps, "paths_per_second": pps[-1],
             "paths_per_cpu_second": statistics.median(r["paths_per_cpu_second"] for r in by[spps[-1]]),
             "relmse_x_spp": [e * s for e, s in zip(rel, spps)], "rounds": len(by[spps[-1]])}
        if len(spps) >= 2:
            fit = common.fit_power(t, rel)
            d["fit_relmse_vs_seconds"] = fit.as_dict()
            d["time_to_relmse"] = [common.time_to_threshold(t, rel, thr, fit) for thr in thresholds]
            d["cpu_time_to_relmse"] = [common.time_to_threshold(cpu, rel, thr) for thr in thresholds]
        out[f"{scene}/{rend}/{samp}"] = d
    return out


def _ratio(a, b):
    return a / b if a is not None and b not in (None, 0) else None


def ratios(ser: dict) -> list[dict]:
    """Every (mcpt sampler, Mitsuba sampler) pair of each scene: mcpt / Mitsuba."""
    out = []
    for a in ser.values():
        if a["renderer"] != "mcpt":
            continue
        for b in ser.values():
            if b["renderer"] != "mitsuba" or b["scene"] != a["scene"]:
                continue
            common_spp = sorted(set(a["spp"]) & set(b["spp"]))
            s = common_spp[-1] if common_spp else None
            tt = [_ratio(x["seconds"], y["seconds"])
                  for x, y in zip(a.get("time_to_relmse", []), b.get("time_to_relmse", []))]
            ct = [_ratio(x["seconds"], y["seconds"])
                  for x, y in zip(a.get("cpu_time_to_relmse", []), b.get("cpu_time_to_relmse", []))]
            out.append({
                "scene": a["scene"], "mcpt": a["sampler"], "mitsuba": b["sampler"],
                "paths_per_second_ratio": _ratio(a["paths_per_second"], b["paths_per_second"]),
                "paths_per_cpu_second_ratio": _ratio(a["paths_per_cpu_second"], b["paths_per_cpu_second"]),
                "thresholds": [x["threshold"] for x in a.get("time_to_relmse", [])],
                "time_to_relmse_ratio": tt, "cpu_time_to_relmse_ratio": ct,
                "equal_spp": s,
                "relmse_ratio_at_equal_spp": (_ratio(a["relmse"][a["spp"].index(s)],
                                                     b["relmse"][b["spp"].index(s)]) if s else None)})
    return out


def summarize(records: list[dict], thresholds=(1e-2, 1e-3)) -> dict:
    ser = series(records, thresholds)
    return {"series": ser, "ratios": ratios(ser)}


def _g(x, fmt=".3g") -> str:
    return "—" if x is None else format(x, fmt)


def summary_lines(summary: dict) -> list[str]:
    """The printed figures: one line per curve, one per (mcpt, Mitsuba) sampler pair."""
    L = []
    for d in summary["series"].values():
        tt = d.get("time_to_relmse", [])
        L.append(f"{d['scene']:20s} {d['label']:38s} {d['paths_per_second'] / 1e6:6.3f} Mpaths/s  "
                 + "  ".join(f"t(relMSE {x['threshold']:g}) {_g(x['seconds'])} s"
                             + ("*" if x["method"] == "extrapolated" else "") for x in tt)
                 + f"  relMSE·spp {_g(d['relmse_x_spp'][-1])}")
    for r in summary["ratios"]:
        L.append(f"{r['scene']:20s} mcpt {r['mcpt']} / Mitsuba {r['mitsuba']}: "
                 f"paths/s {_g(r['paths_per_second_ratio'])}  "
                 + "  ".join(f"time to {t:g} {_g(x)}" for t, x in zip(r["thresholds"], r["time_to_relmse_ratio"]))
                 + f"  relMSE at {r['equal_spp']} spp {_g(r['relmse_ratio_at_equal_spp'])}")
    if summary["series"]:
        L.append("(ratios mcpt / Mitsuba: paths/s > 1 and time-to-error < 1 mean mcpt is ahead; "
                 "* = extrapolated along the log-log fit)")
    return L


def report_lines(summary: dict, settings: dict) -> list[str]:
    """Markdown for PEER.md beside the JSON (and for bench/RESULTS.md)."""
    res = settings["resolution"]
    L = ["# mcpt and Mitsuba 3 side by side", "",
         f"{res[0]}x{res[1]}, {settings['bounces']} bounces, spp {settings['spp']}, "
         f"{settings['rounds']} round(s), alternating ({settings['order']}). Seconds: "
         f"{settings['time']}; relMSE against {settings['reference']}.", ""]
    if summary.get("mitsuba", {}).get("note"):
        L += [summary["mitsuba"]["note"], ""]
    L += ["| scene | renderer, sampler | Mpaths/s | Mpaths/CPU-s | relMSE·spp | time to relMSE 1e-2 | time to 1e-3 |",
          "|---|---|---:|---:|---:|---:|---:|"]
    for d in summary["series"].values():
        tt = d.get("time_to_relmse", [{}, {}])
        cell = [f"{_g(x.get('seconds'))} s" + (" (extrap.)" if x.get("method") == "extrapolated" else "")
                for x in tt]
        L.append(f"| {d['scene']} | {d['label']} | {d['paths_per_second'] / 1e6:.3f} | "
                 f"{d['paths_per_cpu_second'] / 1e6:.3f} | {_g(d['relmse_x_spp'][-1])} | "
                 + " | ".join(cell) + " |")
    if summary["ratios"]:
        L += ["", "Ratios mcpt / Mitsuba (paths/s > 1 and time-to-error < 1: mcpt ahead):", "",
              "| scene | mcpt sampler | Mitsuba sampler | paths/s | time to relMSE 1e-2 | time to 1e-3 "
             "| relMSE at equal spp |",
              "|---|---|---|---:|---:|---:|---:|"]
        for r in summary["ratios"]:
            tt = (r["time_to_relmse_ratio"] + [None, None])[:2]
            L.append(f"| {r['scene']} | {r['mcpt']} | {r['mitsuba']} | {_g(r['paths_per_second_ratio'])} | "
                     f"{_g(tt[0])} | {_g(tt[1])} | {_g(r['relmse_ratio_at_equal_spp'])} ({r['equal_spp']} spp) |")
    L += ["", "![error against time](peer.png)"]
    return L

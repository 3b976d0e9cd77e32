"""Mitsuba 3's measured figures on this kind of machine (../shared/research/peer-mitsuba-data).

These were measured by someone else (Mitsuba 3.9.1, 2 vCPU, same scenes and conventions, see
peer-mitsuba.md); we only read them, to put them beside ours. Times are the median wall seconds of
one ``mi.render`` call (set-up excluded), errors against the same reference.exr.
"""

from __future__ import annotations

import json
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

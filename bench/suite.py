"""Run a set of sweeps: records (JSON), plots (PNG) and the report (Markdown) in one folder.

``run(names, cfg, log)`` is what ``bench/run.py`` and ``mcpt bench`` call. It never exits the
process: a sweep that raises is recorded as failed (``<sweep>.error.txt``), the others still run,
and the returned dict says which failed.
"""

from __future__ import annotations

import time
import traceback
from pathlib import Path

from . import common, peer_run, report, sweeps, throughput

# "all" is the default set; "peer" (mcpt and Mitsuba 3 side by side, issue #14) runs when named.
SWEEPS = {**sweeps.SWEEPS, "throughput": throughput.throughput_sweep, "peer": peer_run.peer_sweep}
ALL = tuple(k for k in SWEEPS if k != "peer")
ALIASES = {"spec": "throughput", "paths": "throughput", "tris": "triangles", "err": "error",
           "bounce": "bounces", "mitsuba": "peer"}


def resolve(names) -> list[str]:
    """Sweep names from user input (comma lists allowed, aliases, 'all'); ValueError if unknown."""
    out: list[str] = []
    for item in names or ["all"]:
        for n in str(item).split(","):
            n = n.strip().lower()
            if not n:
                continue
            if n == "all":
                out += [x for x in ALL if x not in out]
                continue
            n = ALIASES.get(n, n)
            if n not in SWEEPS:
                raise ValueError(f"unknown sweep {n!r}; choose from {', '.join(SWEEPS)} (or all)")
            if n not in out:
                out.append(n)
    return out


def _plots(log):
    """The plotting module, or None (said once) where matplotlib is not installed: an installed
    wheel's `mcpt bench` still measures and reports (pip install matplotlib for the PNGs)."""
    global _PLOTS_WARNED
    try:
        from . import plots
    except ImportError as exc:
        if not _PLOTS_WARNED:
            log(f"plots skipped: {exc.name or 'matplotlib'} is not installed (pip install matplotlib)")
            _PLOTS_WARNED = True
        return None
    return plots


_PLOTS_WARNED = False


def run(names, cfg: sweeps.Config, log=print, argv=None) -> dict:
    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    meta = common.run_meta(sweeps.gl_info(cfg), argv)
    meta["mode"] = "quick" if cfg.quick else "full"
    done, failed, files = [], {}, []
    t_all = time.perf_counter()
    for name in resolve(names):
        log(f"== {name} sweep ({meta['mode']})")
        t0 = time.perf_counter()
        err_file = out / f"{name}.error.txt"
        try:
            res = SWEEPS[name](cfg, log)
        except Exception as exc:  # keep going: one broken sweep must not hide the others
            failed[name] = f"{type(exc).__name__}: {exc}"
            err_file.write_text(traceback.format_exc())
            log(f"!! {name} sweep failed: {failed[name]} (traceback in {err_file})")
            continue
        if err_file.exists():
            err_file.unlink()
        m = {**meta, "time_utc": common.run_meta(meta["gl"], argv)["time_utc"],
             "loadavg_1min": common.loadavg(), "sweep_seconds": time.perf_counter() - t0}
        files.append(common.write_records(out, name, m, res["settings"], res["records"], res["summary"]))
        plots = _plots(log)
        if plots is not None:
            files += plots.PLOTS[name](res, out, m)
        done.append(name)
        log(f"== {name} done in {m['sweep_seconds']:.1f} s")
    files.append(report.write_report(out))
    summary = {"done": done, "failed": failed, "files": [str(f) for f in files],
               "seconds": time.perf_counter() - t_all, "report": str(out / "REPORT.md")}
    log(f"wrote {out / 'REPORT.md'} ({len(done)} sweep(s), {summary['seconds']:.0f} s"
        + (f", FAILED: {', '.join(failed)}" if failed else "") + ")")
    return summary

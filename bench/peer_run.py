"""``mcpt bench --only peer`` (issue #14): mcpt and Mitsuba 3 on the shared reference scenes.

Both renderers render the same scene folder (../shared/scenes-ref/<name>: scene.json + OBJs) at
the same resolution and bounce count, ALTERNATING within each (round, scene, spp): mcpt sampler 1,
Mitsuba sampler 1, mcpt sampler 2, Mitsuba sampler 2, ... so both see the same machine load.
Seconds are each tool's own render timer, set-up excluded (mcpt: its passes incl. host random
numbers and uploads; Mitsuba: one mi.render call plus the copy back). relMSE is computed here,
with common.relmse, for both, against the scene's reference.exr area-averaged to the resolution.
Per (scene, renderer, sampler): seconds are the median over rounds and relMSE the mean over
rounds (seeds differ per round), then time to relMSE 1e-2 / 1e-3 is interpolated on the log-log
(seconds, relMSE) curve (extrapolated along its power-law fit outside the measured range).
Ratios are mcpt / Mitsuba: paths/s ratio > 1 and time-to-error ratio < 1 mean mcpt is ahead.
"""

from __future__ import annotations

import itertools
import resource
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from . import common, mitsuba, scenes
from .peer import report_lines, summarize, summary_lines
from .scenes import ref_scene_yaml

PEER_SCENES = ("cornell", "cornell-sphere-100k")


@dataclass(frozen=True)
class PeerConfig:
    """Quick (``mcpt bench --only peer``, ``make peer``): 128x128, 4..256 spp, 2 rounds, about
    5 min on 2 cores today. Full (``--full``): 256x256 (the issue's size), 2 rounds, 4x as long."""

    scenes: tuple = PEER_SCENES
    resolution: int = 128              # square, pixels; the references are 256x256
    spp: tuple = (4, 16, 64, 256)      # perfect squares: Mitsuba's multijitter keeps them as given
    rounds: int = 2
    mcpt_samplers: tuple | None = None  # None: every sampler this mcpt offers
    mitsuba_samplers: tuple = ("independent", "multijitter")
    variant: str = "llvm_ad_rgb"
    thresholds: tuple = (1e-2, 1e-3)


def peer_config(quick: bool = True, **overrides) -> PeerConfig:
    base = PeerConfig() if quick else PeerConfig(resolution=256)
    return replace(base, **{k: v for k, v in overrides.items() if v is not None})


def ref_scene_dir(name: str) -> Path:
    return scenes.shared_dir() / "scenes-ref" / name


# ------------------------------------------------------------------------------------------------
class _Mcpt:
    """One prepared mcpt scene with one sampler, kept open for the whole run."""

    renderer = "mcpt"

    def __init__(self, path: Path, cfg, res: int, sampler: str):
        from mcpt.api import prepare
        from mcpt.gpu.options import dispatch_flags

        # "sobol@compute" / "sobol@wavefront": the sampler with that dispatch (bench/gpu_peer.py,
        # issue #23); without "@", MCPT_DISPATCH decides as for any render.
        self.sampler = sampler  # kept whole: the records of the two dispatches stay apart
        sampler, _, dispatch = sampler.partition("@")
        self.label = f"mcpt {sampler}" + (f" {dispatch}" if dispatch else "")
        flags = dispatch_flags({"MCPT_DISPATCH": dispatch}) if dispatch else None
        self.p = prepare(path, seed=cfg.seed, resolution=(res, res), gl_backend=cfg.gl_backend,
                         sampler=sampler, feature_flags=flags)
        t0 = time.perf_counter()
        self._render(1, cfg.seed)  # llvmpipe compiles at the first draw
        self.info = {"setup_seconds": self.p.setup_seconds, "triangles": self.p.world.n_triangles,
                     "first_pass_seconds": time.perf_counter() - t0,
                     "features": self.p.features.defines()}

    def run(self, spp: int, seed: int, work: Path) -> tuple[np.ndarray, dict]:
        ru0 = resource.getrusage(resource.RUSAGE_SELF)
        r = self._render(spp, seed)
        ru1 = resource.getrusage(resource.RUSAGE_SELF)
        cpu = (ru1.ru_utime + ru1.ru_stime) - (ru0.ru_utime + ru0.ru_stime)
        return r.image, {"seconds": r.render_seconds, "cpu_seconds": cpu, "spp_actual": spp,
                         "bounces": r.bounces, "random_seconds": r.random_seconds,
                         "dropped_samples": r.dropped_samples}

    def _render(self, spp: int, seed: int):
        from mcpt.api import Options, run

        return run(self.p, Options(spp=spp, seed=seed)).result

    def close(self):
        self.p.renderer.release()


class _Mitsuba:
    renderer = "mitsuba"

    def __init__(self, scene_dir: Path, res: int, sampler: str, variant: str, version: str):
        self.scene_dir, self.res, self.sampler, self.variant = scene_dir, res, sampler, variant
        self.label = f"Mitsuba {version} {variant} {sampler}"
        self.info: dict = {}

    def run(self, spp: int, seed: int, work: Path) -> tuple[np.ndarray, dict]:
        from mcpt.output.image import read_exr

        exr = work / f"mitsuba-{self.scene_dir.name}-{self.sampler}.exr"
        j = mitsuba.render(self.scene_dir, spp=spp, seed=seed, resolution=self.res,
                           sampler=self.sampler, out_exr=exr, variant=self.variant)
        img = np.asarray(read_exr(exr)[0], np.float32)[..., :3]
        self.info = {"t_import_s": j["t_import_s"], "t_load_s": j["t_load_s"], "command": j["command"]}
        return img, {"seconds": j["median_render_s"], "cpu_seconds": j["render_cpu_s"][0],
                     "spp_actual": j["spp_actual"], "bounces": j["bounces"]}

    def close(self):
        pass


# ------------------------------------------------------------------------------------------------
# The sweep
# ------------------------------------------------------------------------------------------------


class _Sides:
    """The renderers of every scene in the order they alternate, and why Mitsuba's side stopped
    (``note``; None while it runs): a failure drops Mitsuba everywhere, keeping what was measured."""

    def __init__(self, log, note: str | None):
        self.log, self.note = log, note
        self.by_scene: dict = {}

    def drop_mitsuba(self, note: str) -> None:
        self.note = note
        self.log(note)
        for other in self.by_scene.values():
            other[:] = [x for x in other if x.renderer != "mitsuba"]


def _scene_sides(name, d, path, cfg, pc, res, wanted, work, avail, sides: _Sides):
    """mcpt's samplers and Mitsuba's for one scene, alternating: mcpt 1, Mitsuba 1, mcpt 2, ..."""
    mc = []
    for s in wanted:
        try:
            mc.append(_Mcpt(path, cfg, res, s))
        except Exception as exc:  # one sampler failing must not hide the others: say so, go on
            sides.log(f"peer: mcpt sampler {s!r} failed on {name}: {type(exc).__name__}: {exc}")
    ms = []
    for s in pc.mitsuba_samplers if sides.note is None else ():
        m = _Mitsuba(d, res, s, pc.variant, avail.version)
        try:  # untimed: fills drjit's kernel cache (the kernel does not depend on spp)
            m.run(pc.spp[0], cfg.seed + 999, work)
            ms.append(m)
        except Exception as exc:  # e.g. llvm_ad_rgb on a libLLVM too old: one line, no Mitsuba
            sides.drop_mitsuba(f"Mitsuba 3 not usable ({pc.variant} {s} on {name}: "
                               f"{type(exc).__name__}: {exc}): skipping its side")
            ms = []
            break
    sides.by_scene[name] = [x for pair in itertools.zip_longest(mc, ms) for x in pair if x is not None]
    return {x.label: x.info for x in mc}


def _measure(pc, cfg, res, refs, work, sides: _Sides) -> list:
    """Every (round, scene, spp, side) render, alternating the sides; one record each."""
    records = []
    for rnd in range(pc.rounds):
        seed = cfg.seed + rnd
        for name, ss in sides.by_scene.items():
            for spp in pc.spp:
                for side in list(ss):
                    if side not in ss:  # dropped by a failure just now
                        continue
                    try:
                        img, m = side.run(spp, seed, work)
                    except mitsuba.MitsubaError as exc:  # keep what was measured; say so once
                        sides.drop_mitsuba(f"Mitsuba 3 failed mid-run ({exc}): its side stops here")
                        continue
                    e = common.errors(img, refs[name])
                    spp_a = m["spp_actual"]
                    rec = {"scene": name, "renderer": side.renderer, "sampler": side.sampler,
                           "label": side.label, "round": rnd, "seed": seed, "spp": spp,
                           "width": res, "height": res, **m, **e,
                           "paths_per_second": res * res * spp_a / max(m["seconds"], 1e-12),
                           "paths_per_cpu_second": res * res * spp_a / max(m["cpu_seconds"], 1e-12),
                           "mean_rgb": [float(x) for x in img.reshape(-1, 3).mean(axis=0)],
                           "loadavg_1min": common.loadavg()}
                    records.append(rec)
                    sides.log(f"round {rnd} {name:20s} {side.label:38s} {spp:4d} spp  "
                              f"{m['seconds']:7.3f} s  {rec['paths_per_second'] / 1e6:6.3f} Mpaths/s  "
                              f"relMSE {e['relmse']:.3e}")
    return records


def peer_sweep(cfg, log=print, pcfg: PeerConfig | None = None) -> dict:
    """``mcpt bench --only peer``: see the module docstring. Returns {settings, records, summary}."""
    from mcpt.gpu.features import SAMPLERS
    from mcpt.output.image import read_exr

    pc = pcfg or peer_config(cfg.quick)
    res = pc.resolution
    out = Path(cfg.out)
    work = out / "peer"
    work.mkdir(parents=True, exist_ok=True)
    wanted = pc.mcpt_samplers or SAMPLERS
    avail = mitsuba.available()
    sides = _Sides(log, None)
    if not avail.ok:
        sides.note = f"Mitsuba 3 not available ({avail.reason}): skipping its side"
        log(sides.note)
    setups, refs, bounces = {}, {}, {}
    for name in pc.scenes:
        d = ref_scene_dir(name)
        if not (d / "reference.exr").exists():
            log(f"peer: {d} has no reference.exr: skipping scene {name}")
            continue
        refs[name] = common.to_resolution(np.asarray(read_exr(d / "reference.exr")[0], np.float32)[..., :3],
                                       res, res)
        yml = ref_scene_yaml(d)
        bounces[name] = yml["render"]["bounces"]
        path = scenes.write(yml, Path(cfg.scene_dir), f"peer-{name}")
        setups[name] = _scene_sides(name, d, path, cfg, pc, res, wanted, work, avail, sides)
    if not refs:
        raise FileNotFoundError(f"none of {pc.scenes} found with a reference.exr under "
                                f"{scenes.shared_dir() / 'scenes-ref'}")
    try:
        records = _measure(pc, cfg, res, refs, work, sides)
    finally:
        for ss in sides.by_scene.values():
            for s in ss:
                s.close()
    mi_note = sides.note
    summary = summarize(records, pc.thresholds)
    summary["mitsuba"] = {"available": mi_note is None, "version": avail.version, "note": mi_note,
                          "python": str(mitsuba.python()), "tool": str(mitsuba.tool())}
    summary["mcpt_samplers"] = list(wanted)
    summary["setup"] = setups
    for line in summary_lines(summary):
        log(line)
    settings = {"scenes": list(refs), "resolution": [res, res], "spp": list(pc.spp),
                "rounds": pc.rounds, "bounces": max(bounces.values()), "seed": cfg.seed,
                "bounces_by_scene": bounces,
                "mcpt_samplers": [s for s in wanted], "mitsuba_samplers": list(pc.mitsuba_samplers),
                "mitsuba_variant": pc.variant, "thresholds": list(pc.thresholds),
                "order": "per (round, scene, spp): mcpt s1, Mitsuba s1, mcpt s2, Mitsuba s2, ...",
                "time": "each tool's render timer, set-up excluded",
                "reference": "<scene>/reference.exr (Mitsuba 3.9.1), area-averaged to the resolution"
                             + ("" if res <= 256 else " (repeated: finer than the reference, see "
                                                      "common.to_resolution)")}
    (out / "PEER.md").write_text("\n".join(report_lines(summary, settings)) + "\n")
    return {"sweep": "peer", "settings": settings, "records": records, "summary": summary}

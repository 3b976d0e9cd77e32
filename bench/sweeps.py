"""The sweeps: each renders with mcpt.api, measures, and returns {settings, records, summary}.

Timing conventions (all seconds, ``time.perf_counter``):

* ``render_seconds``: the passes only, as mcpt's renderer reports it (random numbers, uploads,
  draws, read-backs); set-up (mesh load, BVH build, shader compile, TBO upload) is recorded apart.
* Before any timed render, one 1-pass render of the same renderer runs untimed for the result
  (recorded as ``first_pass_seconds``): llvmpipe compiles the fragment shader to machine code at
  its first draw, which is set-up, not rendering.
* ``paths/s`` = width * height * spp / render_seconds: one path = one camera sample of up to
  ``bounces`` scattering events.

Each function takes a :class:`Config` and a ``log`` callable (one line of progress text) and
never exits or prints on its own.
"""

from __future__ import annotations

import resource
import statistics
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from . import common, peer, scenes

BOUNCES = (1, 2, 3, 5, 8, 15)
THRESHOLDS = (1e-2, 1e-3)


@dataclass(frozen=True)
class Config:
    out: Path = Path("out/bench")
    quick: bool = True
    seed: int = 0
    gl_backend: str | None = None
    # bounce sweep
    bounces: tuple = BOUNCES
    bounce_resolution: tuple = (128, 128)
    bounce_spp: int = 128
    # triangle sweep
    tri_resolution: tuple = (128, 128)
    tri_spp: int = 4
    brute_cap_seconds: float = 20.0
    tri_ladder: tuple = tuple(scenes.TRIANGLE_LADDER)
    # error against time
    err_resolution: tuple = (256, 256)
    err_spp: tuple = (1, 2, 4, 8, 16, 32, 64)
    self_reference_spp: int = 4096     # only when the Mitsuba reference is missing
    # throughput and specialisation
    tp_resolution: tuple = (256, 256)
    tp_spp: int = 8
    tp_repeats: int = 3
    tp_scenes: tuple = ("cornell", "bunny")

    @property
    def cache(self) -> Path:
        return Path(self.out) / "cache"

    @property
    def scene_dir(self) -> Path:
        return Path(self.out) / "scenes"


def config(quick: bool = True, **overrides) -> Config:
    """The quick (``make bench``, a few minutes) or the full set of parameters."""
    base = Config(quick=quick)
    if not quick:
        base = replace(base, bounce_resolution=(256, 256), bounce_spp=256,
                       tri_resolution=(256, 256), tri_spp=16, brute_cap_seconds=120.0,
                       tri_ladder=tuple(scenes.TRIANGLE_LADDER_FULL),
                       err_spp=tuple(2**k for k in range(11)),
                       tp_spp=32, tp_repeats=5)
    return replace(base, **{k: v for k, v in overrides.items() if v is not None})


def _noop(msg: str) -> None:
    pass


@dataclass
class Session:
    """One prepared scene: the Prepared object plus the untimed first pass."""

    p: object
    first_pass_seconds: float = 0.0
    info: dict = field(default_factory=dict)


def _open(path, cfg: Config, *, resolution, bounces=None, features_mode="scene", flags=None,
          clear_shader_cache=False) -> Session:
    from mcpt.api import prepare
    from mcpt.gpu import shader

    if clear_shader_cache:
        shader.clear_cache()  # so compile_seconds is a real compile, not a cache hit
    p = prepare(path, bounces=bounces, seed=cfg.seed, resolution=resolution,
                gl_backend=cfg.gl_backend, features_mode=features_mode, feature_flags=flags)
    t0 = time.perf_counter()
    p.renderer.render(1, cfg.seed)
    first = time.perf_counter() - t0
    setup = p.renderer.setup
    bvh = p.world.stats.get("bvh", {})
    info = {
        "triangles": p.world.n_triangles,
        "setup_seconds": p.setup_seconds,
        "load_seconds": p.world.stats.get("load_seconds"),
        "bvh_build_seconds": bvh.get("build_seconds"),
        "bvh_nodes": bvh.get("nodes"),
        "bvh_depth": bvh.get("depth"),
        "compile_seconds": setup["compile_seconds"],
        "upload_seconds": setup["upload_seconds"],
        "upload_bytes": dict(setup["upload_bytes"]),
        "upload_bytes_total": int(sum(setup["upload_bytes"].values())),
        "random_bytes_per_pass": setup["random_bytes_per_pass"],
        "first_pass_seconds": first,
        "features": p.features.defines(),
    }
    return Session(p, first, info)


def _cpu_seconds() -> float:
    """User + system CPU seconds of this process, all threads (llvmpipe's included)."""
    ru = resource.getrusage(resource.RUSAGE_SELF)
    return ru.ru_utime + ru.ru_stime


def _render(s: Session, spp: int, seed: int) -> tuple[object, dict]:
    c0 = _cpu_seconds()
    t0 = time.perf_counter()
    r = s.p.renderer.render(spp, seed)
    wall = time.perf_counter() - t0
    cpu = _cpu_seconds() - c0
    mean = r.image.reshape(-1, 3).astype(np.float64).mean(axis=0)
    return r, {
        "spp": spp,
        "render_seconds": r.render_seconds,
        "wall_seconds": wall,
        "seconds_per_pass": r.render_seconds / spp,
        "paths_per_second": r.paths_per_second,
        # CPU seconds are steadier than wall seconds when other work shares the two cores
        "cpu_seconds": cpu,
        "paths_per_cpu_second": r.image.shape[0] * r.image.shape[1] * spp / max(cpu, 1e-12),
        "random_seconds": r.random_seconds,
        "random_fraction": r.random_seconds / max(r.render_seconds, 1e-12),
        "dropped_samples": r.dropped_samples,
        "mean_rgb": [float(x) for x in mean],
        "mean_luminance": common.luminance(mean),
    }


def gl_info(cfg: Config) -> dict:
    from mcpt.gpu.context import shared_context

    return shared_context(cfg.gl_backend).describe()


def _scene_path(cfg: Config, data: dict, name: str | None = None) -> Path:
    return scenes.write(data, cfg.scene_dir, name)


# ------------------------------------------------------------------------------------------------
# Bounce sweep
# ------------------------------------------------------------------------------------------------


def bounce_sweep(cfg: Config, log=_noop) -> dict:
    from mcpt.output.image import write_image

    path = _scene_path(cfg, scenes.cornell(), "cornell")
    w, h = cfg.bounce_resolution
    img_dir = Path(cfg.out) / "bounces"
    img_dir.mkdir(parents=True, exist_ok=True)
    records = []
    for b in cfg.bounces:
        # variance on: the standard error of each mean says whether a step is above the noise
        s = _open(path, cfg, resolution=(w, h), bounces=b, flags={"variance": True})
        try:
            r, m = _render(s, cfg.bounce_spp, cfg.seed)
        finally:
            s.p.renderer.release()
        npix = r.image.shape[0] * r.image.shape[1]
        se_rgb = np.sqrt(r.variance.reshape(-1, 3).astype(np.float64).sum(axis=0)) / npix
        lum_w = np.array([0.2126, 0.7152, 0.0722])
        m["mean_stderr_rgb"] = [float(x) for x in se_rgb]
        m["mean_luminance_stderr"] = float(np.sqrt((r.variance.reshape(-1, 3).astype(np.float64)
                                                    @ lum_w**2).sum()) / npix)
        png = img_dir / f"bounces-{b:02d}.png"
        write_image(png, r.image, None, 0.0)
        rec = {"scene": "cornell", "bounces": b, "width": w, "height": h, "seed": cfg.seed,
               **m, "setup": s.info, "image": str(png.relative_to(cfg.out)),
               "loadavg_1min": common.loadavg()}
        records.append(rec)
        log(f"bounces {b:2d}: mean {m['mean_luminance']:.5f} ± {m['mean_luminance_stderr']:.5f}  "
            f"{m['render_seconds']:.2f} s  "
            f"{m['paths_per_second'] / 1e6:.3f} Mpaths/s")
    lum = [r["mean_luminance"] for r in records]
    conv = common.converges(lum)
    se = [r["mean_luminance_stderr"] for r in records]
    # standard error of each step (independent renders: the variances add)
    step_se = [float(np.hypot(a, b)) for a, b in zip(se, se[1:])]
    summary = {"mean_luminance": lum, "mean_luminance_stderr": se, **conv, "steps_stderr": step_se,
               "relative_steps": [d / lum[-1] for d in conv["steps"]] if lum[-1] else None}
    settings = {"scene": "cornell", "bounces": list(cfg.bounces), "resolution": [w, h],
                "spp": cfg.bounce_spp, "seed": cfg.seed}
    return {"sweep": "bounces", "settings": settings, "records": records, "summary": summary}


# ------------------------------------------------------------------------------------------------
# Triangle sweep
# ------------------------------------------------------------------------------------------------


def triangle_sweep(cfg: Config, log=_noop) -> dict:
    w, h = cfg.tri_resolution
    paths_per_pass = w * h
    passes = cfg.tri_spp + 1  # + the untimed first pass, which also costs time
    records = []
    cost = None               # brute force: seconds per (path x triangle), from the last level
    capped = False
    for level in cfg.tri_ladder:
        t0 = time.perf_counter()
        path = _scene_path(cfg, level.scene(cfg.cache), "tri-" + level.label.replace(" /", "-sub")
                           .replace(" ", "-"))
        prep_s = time.perf_counter() - t0
        # BVH, forced on even where the scene's features would choose the loop (< 64 triangles).
        s = _open(path, cfg, resolution=(w, h), flags={"bvh": True})
        try:
            _, m = _render(s, cfg.tri_spp, cfg.seed)
        finally:
            s.p.renderer.release()
            n = s.info["triangles"]
            del s.p
        rec = {"scene": level.label, "triangles": n, "accel": "bvh", "status": "ok",
               "width": w, "height": h, "seed": cfg.seed, "scene_build_seconds": prep_s, **m,
               "setup": s.info, "loadavg_1min": common.loadavg()}
        records.append(rec)
        log(f"triangles {n:>9,d} bvh   {m['seconds_per_pass'] * 1e3:8.1f} ms/pass  "
            f"build {s.info['bvh_build_seconds']:.2f} s  "
            f"{s.info['upload_bytes_total'] / 2**20:.1f} MiB")
        # Brute force, unless the projected time passes the cap.
        projected = cost * n * paths_per_pass * passes if cost is not None else None
        if capped or (projected is not None and projected > cfg.brute_cap_seconds):
            capped = True
            records.append({"scene": level.label, "triangles": n, "accel": "brute",
                            "status": "capped", "projected_seconds": projected,
                            "cap_seconds": cfg.brute_cap_seconds, "width": w, "height": h})
            log(f"triangles {n:>9,d} brute capped (projected "
                f"{projected if projected is not None else float('nan'):.0f} s > "
                f"{cfg.brute_cap_seconds:.0f} s)")
            continue
        s = _open(path, cfg, resolution=(w, h), flags={"bvh": False})
        try:
            _, m = _render(s, cfg.tri_spp, cfg.seed)
        finally:
            s.p.renderer.release()
            del s.p
        cost = (m["render_seconds"] + s.first_pass_seconds) / (n * paths_per_pass * passes)
        records.append({"scene": level.label, "triangles": n, "accel": "brute", "status": "ok",
                        "projected_seconds": projected, "cap_seconds": cfg.brute_cap_seconds,
                        "width": w, "height": h, "seed": cfg.seed, **m, "setup": s.info,
                        "loadavg_1min": common.loadavg()})
        log(f"triangles {n:>9,d} brute {m['seconds_per_pass'] * 1e3:8.1f} ms/pass")
    return {"sweep": "triangles", "records": records, "summary": triangle_summary(records),
            "settings": {"resolution": [w, h], "spp": cfg.tri_spp, "bounces": 8, "seed": cfg.seed,
                         "brute_cap_seconds": cfg.brute_cap_seconds,
                         "ladder": [lv.label for lv in cfg.tri_ladder]}}


def triangle_summary(records: list[dict]) -> dict:
    bvh = [r for r in records if r["accel"] == "bvh" and r["status"] == "ok"]
    brute = [r for r in records if r["accel"] == "brute" and r["status"] == "ok"]
    capped = [r for r in records if r["accel"] == "brute" and r["status"] == "capped"]
    out: dict = {
        "max_triangles_bvh": max((r["triangles"] for r in bvh), default=0),
        "max_triangles_brute": max((r["triangles"] for r in brute), default=0),
        "brute_capped_from": min((r["triangles"] for r in capped), default=None),
    }
    if len(bvh) >= 2:
        n = [r["triangles"] for r in bvh]
        t = [r["seconds_per_pass"] for r in bvh]
        out["bvh_log_fit"] = common.fit_log(n, t).as_dict()
        out["bvh_time_ratio_max_vs_min"] = t[-1] / t[0]
        out["bvh_triangle_ratio_max_vs_min"] = n[-1] / n[0]
        build = [(r["triangles"], r["setup"]["bvh_build_seconds"]) for r in bvh
                 if r["triangles"] >= 1000]
        if len(build) >= 2:
            out["bvh_build_fit"] = common.fit_power(*zip(*build)).as_dict()
        # The same bunny at 1x, 4x, 16x triangles: only the BVH changes, not the picture.
        bun = [r for r in bvh if r["scene"].startswith("bunny")]
        if len(bun) >= 2:
            out["bunny_subdivision"] = {
                "triangles": [r["triangles"] for r in bun],
                "seconds_per_pass": [r["seconds_per_pass"] for r in bun],
                "time_ratio": bun[-1]["seconds_per_pass"] / bun[0]["seconds_per_pass"],
                "triangle_ratio": bun[-1]["triangles"] / bun[0]["triangles"],
            }
    if brute and bvh:
        by_n = {r["triangles"]: r for r in bvh}
        faster = [r["triangles"] for r in brute
                  if r["triangles"] in by_n and r["seconds_per_pass"] < by_n[r["triangles"]]["seconds_per_pass"]]
        out["brute_faster_up_to"] = max(faster, default=None)
        out["brute_vs_bvh_time_ratio"] = {
            str(r["triangles"]): r["seconds_per_pass"] / by_n[r["triangles"]]["seconds_per_pass"]
            for r in brute if r["triangles"] in by_n}
    return out


# ------------------------------------------------------------------------------------------------
# Error against run time
# ------------------------------------------------------------------------------------------------


def load_reference(cfg: Config, path: Path, log=_noop) -> tuple[np.ndarray, dict]:
    """The Mitsuba 3 reference (area-averaged down to the sweep's resolution), or, when it is
    missing, an mcpt rendering at ``self_reference_spp`` with an unrelated seed (said so)."""
    from mcpt.output.image import read_exr

    w, h = cfg.err_resolution
    ref_file = scenes.cornell_reference()
    if ref_file.exists():
        ref, _ = read_exr(ref_file)
        ref = common.downsample(np.asarray(ref, np.float32)[..., :3], w, h)
        return ref, {"kind": "mitsuba", "file": str(ref_file),
                     "note": "Mitsuba 3.9.1 llvm_ad_rgb, 32768 spp, 256x256"
                             + (f", area-averaged to {w}x{h}" if (w, h) != (256, 256) else "")}
    log(f"no reference at {ref_file}: rendering one with mcpt at {cfg.self_reference_spp} spp")
    ref_seed = cfg.seed + 1_000_003
    s = _open(path, cfg, resolution=(w, h))
    try:
        r, _ = _render(s, cfg.self_reference_spp, ref_seed)
    finally:
        s.p.renderer.release()
    return r.image, {"kind": "mcpt-self", "spp": cfg.self_reference_spp, "seed": ref_seed,
                     "note": f"mcpt's own rendering at {cfg.self_reference_spp} spp (seed {ref_seed});"
                             " it cannot show a bias shared with mcpt"}


def error_sweep(cfg: Config, log=_noop) -> dict:
    path = _scene_path(cfg, scenes.cornell(), "cornell")
    w, h = cfg.err_resolution
    ref, ref_info = load_reference(cfg, path, log)
    from mcpt.output import denoise

    # With OIDN (mcpt[denoise]) each render also yields the albedo and normal AOVs (the beauty is
    # bit-identical with or without them) and a denoised image: a second, BIASED curve (issue #12).
    dn = denoise.available()
    s = _open(path, cfg, resolution=(w, h), flags={"aov": True} if dn else None)
    records = []
    try:
        for spp in cfg.err_spp:
            r, m = _render(s, spp, cfg.seed)
            e = common.errors(r.image, ref)
            extra = {}
            if dn:
                t0 = time.perf_counter()
                img = denoise.denoise(r.image, r.aovs["albedo"], r.aovs["normal"])
                dt = time.perf_counter() - t0
                extra = {"denoise_seconds": dt,
                         "denoised_relmse": common.errors(img, ref)["relmse"]}
            records.append({"scene": "cornell", "width": w, "height": h, "bounces": r.bounces,
                            "seed": cfg.seed, **m, **e, "relmse_x_spp": e["relmse"] * spp,
                            **extra, "loadavg_1min": common.loadavg()})
            log(f"spp {spp:5d}: {m['render_seconds']:7.2f} s  relMSE {e['relmse']:.3e}  "
                f"RMSE {e['rmse']:.4f}  MAE {e['mae']:.4f}"
                + (f"  denoised relMSE {extra['denoised_relmse']:.3e} (biased)" if extra else ""))
    finally:
        s.p.renderer.release()
    summary = error_summary(records)
    summary["reference"] = ref_info
    summary["reference_mean_rgb"] = [float(x) for x in ref.reshape(-1, 3).mean(axis=0)]
    summary["setup"] = s.info
    summary["peer"] = peer.error_figures(THRESHOLDS)
    return {"sweep": "error", "records": records, "summary": summary,
            "settings": {"scene": "cornell", "resolution": [w, h], "spp": list(cfg.err_spp),
                         "bounces": 8, "seed": cfg.seed, "time": "render_seconds (set-up excluded)"}}


def error_summary(records: list[dict]) -> dict:
    t = [r["render_seconds"] for r in records]
    spp = [r["spp"] for r in records]
    rel = [r["relmse"] for r in records]
    out: dict = {}
    if len(records) >= 2:
        fit_t = common.fit_power(t, rel)
        out["fit_relmse_vs_seconds"] = fit_t.as_dict()
        out["fit_relmse_vs_spp"] = common.fit_power(spp, rel).as_dict()
        out["fit_rmse_vs_seconds"] = common.fit_power(t, [r["rmse"] for r in records]).as_dict()
        out["fit_mae_vs_seconds"] = common.fit_power(t, [r["mae"] for r in records]).as_dict()
        out["time_to_relmse"] = [common.time_to_threshold(t, rel, thr, fit_t) for thr in THRESHOLDS]
        out["spp_to_relmse"] = [common.time_to_threshold(spp, rel, thr) for thr in THRESHOLDS]
        # Unbiased Monte Carlo converges as 1/spp; a stratified sampler (sobol) may converge faster
        # at these spp, never slower: the check is "at least as fast as 1/spp, within 0.15".
        out["slope_at_least_minus_1"] = fit_t.slope <= -1.0 + 0.15
        # CPU seconds (both llvmpipe threads): steadier than wall time on a shared machine, and
        # comparable with the peer study's CPU seconds
        cpu = [r["cpu_seconds"] for r in records]
        fit_c = common.fit_power(cpu, rel)
        out["fit_relmse_vs_cpu_seconds"] = fit_c.as_dict()
        out["cpu_time_to_relmse"] = [common.time_to_threshold(cpu, rel, thr, fit_c) for thr in THRESHOLDS]
    out["relmse_x_spp"] = [r["relmse_x_spp"] for r in records]
    out["paths_per_second_median"] = statistics.median(r["paths_per_second"] for r in records)
    return out


SWEEPS = {
    "bounces": bounce_sweep,
    "triangles": triangle_sweep,
    "error": error_sweep,
}

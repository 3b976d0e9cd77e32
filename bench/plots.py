"""PNG plots of the sweep results (matplotlib, Agg back end; no display needed).

Each function takes one sweep's result dict (as written to ``<sweep>.json``) and the output folder,
and returns the paths of the PNGs it wrote. Every plot has a title, axis labels with units and a
legend, so it reads without the report around it.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from . import common, peer  # noqa: E402

DPI = 110


def _save(fig, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    if fig.get_layout_engine() is None:
        fig.tight_layout()
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def _loglog(ax, xlabel: str, ylabel: str, title: str, x_base: int = 10) -> None:
    """Log-log axes with labels, title, grid and legend: the frame every sweep plot shares."""
    ax.set_xscale("log", base=x_base)
    ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)


def _gl_note(meta: dict | None) -> str:
    if not meta:
        return ""
    gl = meta.get("gl", {})
    return f"{gl.get('renderer', '?')}, {meta.get('machine', {}).get('cpus', '?')} CPUs"


# ------------------------------------------------------------------------------------------------


def plot_bounces(res: dict, out: Path, meta: dict | None = None) -> list[Path]:
    recs = res["records"]
    st = res["settings"]
    b = [r["bounces"] for r in recs]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
    for i, (c, name) in enumerate(zip(("tab:red", "tab:green", "tab:blue"), ("R", "G", "B"))):
        a1.plot(b, [r["mean_rgb"][i] for r in recs], "o-", color=c, lw=1, ms=4, label=f"mean {name}")
    a1.plot(b, [r["mean_luminance"] for r in recs], "s-", color="k", lw=2, label="mean luminance")
    a1.set_xlabel("bounces (max scattering events)")
    a1.set_ylabel("mean image radiance (W sr$^{-1}$ m$^{-2}$, linear)")
    conv = res["summary"].get("converges")
    a1.set_title(f"Brightness against bounces ({'converges' if conv else 'NOT converged'})")
    a1.set_xticks(b)
    a1.grid(alpha=0.3)
    a1.legend(fontsize=8, loc="lower right")
    a2.plot(b, [r["paths_per_second"] / 1e6 for r in recs], "o-", label=f"mcpt ({st['resolution'][0]}x"
            f"{st['resolution'][1]}, {st['spp']} spp)")
    pb = peer.bounce_figures()
    if pb:
        a2.plot(pb["bounces"], [x / 1e6 for x in pb["paths_per_second"]], "s--", color="gray",
                label=pb["label"])
    a2.set_xlabel("bounces (max scattering events)")
    a2.set_ylabel("throughput (million paths / s)")
    a2.set_yscale("log")
    a2.set_title("Paths per second against bounces (set-up excluded)")
    a2.set_xticks(b)
    a2.grid(alpha=0.3, which="both")
    a2.legend(fontsize=8)
    fig.suptitle(f"Bounce sweep: Cornell box — {_gl_note(meta)}", fontsize=9)
    paths = [_save(fig, out / "bounces.png")]
    # Contact sheet of the images.
    imgs = [(r, out / r["image"]) for r in recs if (out / r["image"]).exists()]
    if imgs:
        fig, axes = plt.subplots(1, len(imgs), figsize=(2.2 * len(imgs), 2.8), layout="constrained")
        for ax, (r, p) in zip(np.atleast_1d(axes), imgs):
            ax.imshow(plt.imread(p))
            ax.set_title(f"{r['bounces']} bounce{'s' if r['bounces'] != 1 else ''}\n"
                         f"mean L {r['mean_luminance']:.4f}", fontsize=8)
            ax.axis("off")
        fig.suptitle(f"Cornell box at {st['spp']} spp, {st['resolution'][0]}x{st['resolution'][1]}, "
                     "sRGB, no exposure change", fontsize=9)
        paths.append(_save(fig, out / "bounces-sheet.png"))
    return paths


# ------------------------------------------------------------------------------------------------


def plot_triangles(res: dict, out: Path, meta: dict | None = None) -> list[Path]:
    recs = res["records"]
    st = res["settings"]
    w, h = st["resolution"]
    bvh = [r for r in recs if r["accel"] == "bvh" and r["status"] == "ok"]
    brute = [r for r in recs if r["accel"] == "brute" and r["status"] == "ok"]
    capped = [r for r in recs if r["accel"] == "brute" and r["status"] == "capped"]
    us = lambda r: r["seconds_per_pass"] / (w * h) * 1e6  # noqa: E731  microseconds per path

    fig, (a1, a2, a3) = plt.subplots(1, 3, figsize=(15, 4.8), layout="constrained")
    n = [r["triangles"] for r in bvh]
    a1.plot(n, [us(r) for r in bvh], "o-", color="tab:blue", label="mcpt, BVH")
    if brute:
        a1.plot([r["triangles"] for r in brute], [us(r) for r in brute], "s-", color="tab:red",
                label="mcpt, brute force (no BVH)")
    if capped:
        last = us(brute[-1]) if brute else 1.0
        cap_y = [r["projected_seconds"] / (st["spp"] + 1) / (w * h) * 1e6
                 if r.get("projected_seconds") else last for r in capped]
        a1.plot([r["triangles"] for r in capped], cap_y, "x", color="tab:red", ms=8, mew=1.5, alpha=0.6,
                label=f"brute force NOT run: projected time > {st['brute_cap_seconds']:.0f} s cap")
        a1.axvline(capped[0]["triangles"], color="tab:red", ls=":", lw=1)
    fitd = res["summary"].get("bvh_log_fit")
    if fitd and len(n) >= 2:
        xs = np.geomspace(min(n), max(n), 50)
        f = common.LogFit(fitd["a"], fitd["b_per_decade"], fitd["r2"], fitd["points"])
        a1.plot(xs, f.predict(xs) / (w * h) * 1e6, "--", color="tab:blue", lw=1, alpha=0.7,
                label=f"fit a + b·log10(N), b = {fitd['b_per_decade'] / (w * h) * 1e6:.2f} µs/decade")
    pt = peer.triangle_figures()
    if pt:
        a1.plot(pt["triangles"], [1e6 / x for x in pt["paths_per_second"]], "^--", color="gray",
                label=pt["label"])
    for r in bvh:
        a1.annotate(r["scene"], (r["triangles"], us(r)), fontsize=6, xytext=(3, -9),
                    textcoords="offset points")
    _loglog(a1, "triangles in the scene", "render time per path (µs, 8 bounces)",
            f"Render time against triangles ({w}x{h}, {st['spp']} spp)")

    a2.plot(n, [r["setup"]["bvh_build_seconds"] for r in bvh], "o-", label="BVH build (numpy)")
    a2.plot(n, [r["setup"]["load_seconds"] for r in bvh], "s-", label="mesh load (assimp, transform)")
    a2.plot(n, [r["setup"]["upload_seconds"] for r in bvh], "^-", label="TBO upload + shader set-up")
    _loglog(a2, "triangles in the scene", "seconds", "Set-up seconds against triangles")

    mib = lambda b: b / 2**20  # noqa: E731
    a3.plot(n, [mib(r["setup"]["upload_bytes"].get("tris", 0)) for r in bvh], "o-", label="triangles TBO")
    a3.plot(n, [mib(r["setup"]["upload_bytes"].get("nodes", 0)) for r in bvh], "s-", label="BVH nodes TBO")
    a3.plot(n, [mib(r["setup"]["upload_bytes_total"]) for r in bvh], "k--", lw=1, label="all scene TBOs")
    _loglog(a3, "triangles in the scene", "bytes uploaded (MiB)", "Texture-buffer bytes against triangles")
    fig.suptitle(f"Triangle sweep — {_gl_note(meta)}", fontsize=9)
    return [_save(fig, out / "triangles.png")]


# ------------------------------------------------------------------------------------------------


def plot_error(res: dict, out: Path, meta: dict | None = None) -> list[Path]:
    recs = res["records"]
    sm = res["summary"]
    st = res["settings"]
    t = [r["render_seconds"] for r in recs]
    rel = [r["relmse"] for r in recs]
    spp = [r["spp"] for r in recs]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.8), layout="constrained")
    a1.plot(t, rel, "o", color="tab:blue", label="mcpt (GLSL on llvmpipe)")
    if all("denoised_relmse" in r for r in recs):  # mcpt[denoise] installed: OIDN on each render
        a1.plot([r["render_seconds"] + r["denoise_seconds"] for r in recs],
                [r["denoised_relmse"] for r in recs], "v--", color="tab:purple", ms=5, lw=1,
                label="mcpt + OIDN denoiser (BIASED; time includes denoising)")
    fd = sm.get("fit_relmse_vs_seconds")
    if fd:
        xs = np.geomspace(min(t) / 2, max(t) * 20, 50)
        a1.plot(xs, fd["c"] * xs ** fd["slope"], "-", color="tab:blue", lw=1,
                label=f"mcpt fit: relMSE ∝ t^{fd['slope']:.3f} (R² {fd['r2']:.3f})")
    for tt in sm.get("time_to_relmse", []):
        if tt["seconds"]:
            a1.plot([tt["seconds"]], [tt["threshold"]], "*", ms=11, color="tab:blue",
                    mec="k", mew=0.5)
            a1.annotate(f"{tt['seconds']:.2g} s ({tt['method']})", (tt["seconds"], tt["threshold"]),
                        fontsize=7, xytext=(5, 5), textcoords="offset points")
    colors = {"llvm": "tab:gray", "scalar": "tab:olive"}
    for v, d in sm.get("peer", {}).items():
        a1.plot(d["seconds"], d["relmse"], "s--", color=colors.get(v, "k"), ms=4, lw=1,
                label=f"{d['label']} (peer, same reference)")
    for thr in (1e-2, 1e-3):
        a1.axhline(thr, color="k", ls=":", lw=0.8)
    _loglog(a1, "render seconds (set-up excluded)", "relMSE = mean((x−ref)² / (ref² + 0.01))",
            f"Error against run time: Cornell {st['resolution'][0]}x{st['resolution'][1]}, 8 bounces")

    a2.plot(spp, [r["rmse"] for r in recs], "o-", label="RMSE")
    a2.plot(spp, [r["mae"] for r in recs], "s-", label="MAE")
    a2.plot(spp, rel, "^-", label="relMSE")
    s0 = np.array(spp, float)
    a2.plot(s0, recs[0]["rmse"] * (s0 / s0[0]) ** -0.5, "k:", lw=1, label="∝ spp^-1/2 (guide)")
    a2.plot(s0, rel[0] * (s0 / s0[0]) ** -1.0, "k--", lw=1, label="∝ spp^-1 (guide)")
    _loglog(a2, "samples per pixel", "error against the reference (linear radiance)",
            f"Error against samples per pixel (seed {st['seed']})", x_base=2)
    ref = sm.get("reference", {})
    fig.suptitle(f"Reference: {ref.get('note', '?')} — {_gl_note(meta)}", fontsize=9)
    return [_save(fig, out / "error.png")]


# ------------------------------------------------------------------------------------------------


def plot_throughput(res: dict, out: Path, meta: dict | None = None) -> list[Path]:
    sm = res["summary"]
    st = res["settings"]
    names = list(sm["scenes"])
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 5.6), layout="constrained")
    x = np.arange(len(names))
    wdt = 0.35
    spec = [(sm["scenes"][n]["paths_per_second"] or 0.0) / 1e6 for n in names]
    allf = [(sm["scenes"][n]["paths_per_second_all"] or 0.0) / 1e6 for n in names]
    b1 = a1.bar(x - wdt / 2, spec, wdt, label="mcpt, specialised shader (--features scene)")
    b2 = a1.bar(x + wdt / 2, allf, wdt, label="mcpt, uber-shader (--features all)")
    a1.bar_label(b1, fmt="%.3f", fontsize=7)
    a1.bar_label(b2, fmt="%.3f", fontsize=7)
    pk = sm.get("peer", {})
    for i, (_v, d) in enumerate(pk.items()):
        if "cornell" in names:
            a1.axhline(d["paths_per_second"] / 1e6, color=("gray", "olive")[i % 2], ls="--", lw=1,
                       label=f"{d['label']}, Cornell ({d['paths_per_second'] / 1e6:.2f})")
    a1.set_xticks(x, [f"{n}\n({sm['scenes'][n]['triangles'] or 0:,d} triangles)" for n in names])
    a1.set_ylabel("throughput (million paths / s)")
    a1.set_yscale("log")
    a1.set_title(f"Paths per second, {st['resolution'][0]}x{st['resolution'][1]}, 8 bounces, "
                 f"{st['spp']} spp (set-up excluded)")
    a1.grid(alpha=0.3, axis="y", which="both")
    for i, n in enumerate(names):
        for off, key in ((-wdt / 2, "paths_per_second"), (wdt / 2, "paths_per_second_all")):
            if not sm["scenes"][n].get(key):
                a1.annotate("failed", (x[i] + off, 0.5), xycoords=("data", "axes fraction"),
                            ha="center", fontsize=8, color="tab:red", rotation=90)
    a1.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2)

    def pair(key, n):
        d = sm["scenes"][n].get(key) or {}
        return (d.get("scene") or 0.0, d.get("all") or 0.0)  # a failed mode draws as 0

    comp = [pair("cold_compile_seconds", n) for n in names]
    jit = [pair("cold_jit_seconds", n) for n in names]
    a2.bar(x - wdt / 2, [c[0] for c in comp], wdt, color="tab:blue",
           label="GLSL compile + link, specialised")
    a2.bar(x + wdt / 2, [c[1] for c in comp], wdt, color="tab:orange",
           label="GLSL compile + link, uber-shader")
    a2.bar(x - wdt / 2, [j[0] for j in jit], wdt, bottom=[c[0] for c in comp], color="tab:blue",
           alpha=0.4, hatch="//", label="llvmpipe code generation at first draw, specialised")
    a2.bar(x + wdt / 2, [j[1] for j in jit], wdt, bottom=[c[1] for c in comp], color="tab:orange",
           alpha=0.4, hatch="//", label="llvmpipe code generation at first draw, uber-shader")
    a2.set_xticks(x, names)
    a2.set_ylabel("seconds")
    a2.set_title("Shader compile seconds (fresh process, Mesa shader cache off)")
    a2.grid(alpha=0.3, axis="y")
    a2.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2)
    fig.suptitle(f"Throughput and specialisation — {_gl_note(meta)}", fontsize=9)
    return [_save(fig, out / "throughput.png")]


def plot_peer(res: dict, out: Path, meta: dict | None = None) -> list[Path]:
    """relMSE against render seconds, log-log: every mcpt and Mitsuba curve, one panel a scene."""
    ser = res["summary"]["series"]
    st = res["settings"]
    names = list(dict.fromkeys(d["scene"] for d in ser.values())) or ["(no data)"]
    fig, axes = plt.subplots(1, len(names), figsize=(6.2 * len(names), 4.8), layout="constrained",
                             squeeze=False)
    marks = {"mcpt": ("o", "-"), "mitsuba": ("s", "--")}
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, name in zip(axes[0], names):
        curves = [d for d in ser.values() if d["scene"] == name]
        for i, d in enumerate(curves):
            c = colors[i % len(colors)]
            mk, ls = marks.get(d["renderer"], ("^", ":"))
            fit = d.get("fit_relmse_vs_seconds")
            slope = f", slope {fit['slope']:.2f}" if fit else ""
            ax.plot(d["seconds"], d["relmse"], mk + ls, color=c, ms=4, lw=1,
                    label=f"{d['label']} ({d['paths_per_second'] / 1e6:.2f} Mpaths/s{slope})")
            for s, t, e in zip(d["spp"], d["seconds"], d["relmse"]):
                ax.annotate(str(s), (t, e), fontsize=6, color=c, xytext=(3, 3), textcoords="offset points")
            for tt in d.get("time_to_relmse", []):
                if tt["seconds"]:
                    ax.plot([tt["seconds"]], [tt["threshold"]], "*", ms=10, color=c, mec="k", mew=0.5,
                            alpha=1.0 if tt["method"] == "interpolated" else 0.5)
        for thr in st.get("thresholds", (1e-2, 1e-3)):
            ax.axhline(thr, color="k", ls=":", lw=0.8)
        _loglog(ax, "render seconds (each tool's timer, set-up excluded)",
                "relMSE = mean((x−ref)² / (ref² + 0.01))",
                f"{name}: {st['resolution'][0]}x{st['resolution'][1]}, {st['bounces']} bounces, "
                f"{st['rounds']} round(s)")
    fig.suptitle("mcpt and Mitsuba 3 side by side, alternating in one run (labels: spp; stars: time "
                 f"to relMSE, faint = extrapolated) — {_gl_note(meta)}", fontsize=9)
    return [_save(fig, out / "peer.png")]


PLOTS = {"bounces": plot_bounces, "triangles": plot_triangles, "error": plot_error,
         "throughput": plot_throughput, "peer": plot_peer}

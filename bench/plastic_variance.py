"""Per-renderer noise on a Mitsuba XML scene (issue #21, "Variance": the plastic material preview).

    python -m mcpt.bench.plastic_variance SCENE.xml [--spp 64] [--runs 8] [--resolution 96x72]
                                          [--samplers independent,sobol] [--seed 11]
                                          [--mitsuba-cache F.npz] [--json F]

Each renderer renders the scene ``--runs`` times at ``--spp`` (mcpt: seeds ``seed .. seed+R-1``
through its CLI; Mitsuba 3: one ``run_mitsuba`` process per run, seeds ``0 .. R-1``, the scene's
own sampler), so the spread of the R images gives each pixel's variance of ONE ``spp`` image on
each side. (The variance of one run is what is compared: ``run_mitsuba`` with ``--runs R`` splits
``spp`` over the runs, so its ``var_mean`` times R is the variance of a ``spp / R`` image, not of a
``spp`` one.) Per pixel, ``rv = var / (ref^2 + 0.01)`` averaged over RGB, ``ref`` being Mitsuba's
mean image (the relMSE a renderer's image would have against the truth; bench/common.py's eps),
and reported per mcpt sampler:

* ``ratio``: mean rv of mcpt over mean rv of Mitsuba (relMSE ratio at equal spp, < 1: mcpt better);
* ``ratio_trim``: the same with each side's top 1 % of pixels (by rv) dropped;
* ``top1_share``: the share of each side's total rv in its top 1 % of pixels (fireflies);
* ``*_se``: delete-one jackknife standard errors over the R runs (heavy tails make these
  indicative only: a firefly seen in one run of R moves the estimate by about 1/R of itself).

``--mitsuba-cache F.npz`` keeps Mitsuba's R images (rendered once if F is missing), so a before /
after comparison of mcpt uses the same reference and the same Mitsuba noise. Mitsuba runs in the
peer venv (``$MCPT_PEER_PYTHON``, bench/mitsuba.py).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

EPS = 0.01
TOP = 0.01


def mcpt_runs(scene: Path, spp: int, runs: int, seed: int, sampler: str, resolution: str,
              tmp: Path) -> tuple[np.ndarray, float]:
    """R images (R, H, W, 3) of mcpt's CLI at ``spp``, seeds ``seed .. seed + R - 1``, and the
    mean render seconds of a run (its render loop, as the differential harness reports)."""
    from mcpt.output.image import read_exr_channels

    images, seconds = [], []
    for k in range(runs):
        out = tmp / f"mcpt_{sampler}_{k}.exr"
        cmd = [sys.executable, "-m", "mcpt", "render", str(scene), "--spp", str(spp), "--seed", str(seed + k),
               "--sampler", sampler, "-o", str(out), "--progress", "none", "--resolution", resolution, "--json"]
        res = subprocess.run(cmd, capture_output=True, text=True)
        if res.returncode != 0:
            raise RuntimeError(f"mcpt failed: {res.stderr.strip()[-600:]}")
        seconds.append(json.loads(res.stdout)["render_seconds"])
        ch = read_exr_channels(out)
        images.append(np.stack([ch[c] for c in "RGB"], -1).astype(np.float64))
    return np.stack(images), float(np.mean(seconds))


def mitsuba_runs(scene: Path, spp: int, runs: int, resolution: str, tmp: Path) -> np.ndarray:
    """R independent Mitsuba images at ``spp`` each (one process per run: ``runs=1``)."""
    from .differential import run_mitsuba

    return np.stack([run_mitsuba(scene, spp, k, [], 1, tmp, resolution)["mean"] for k in range(runs)])


def pixel_rv(images: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Each pixel's variance of one image (from the spread of the runs) over ref^2 + eps, RGB mean."""
    return (images.var(axis=0, ddof=1) / (ref * ref + EPS)).mean(axis=-1).ravel()


def summary(rv: np.ndarray) -> dict:
    """Mean rv, mean rv without the top 1 % of pixels, and the top 1 %'s share of the total."""
    s = np.sort(rv)
    keep = int(round((1.0 - TOP) * s.size))
    total = float(s.sum())
    return {"rv": total / s.size, "rv_trim": float(s[:keep].mean()),
            "top1_share": float(s[keep:].sum() / total) if total > 0 else 0.0}


def jackknife(images: np.ndarray, ref: np.ndarray) -> tuple[dict, dict]:
    """summary() of all R runs, and its delete-one jackknife standard errors."""
    full = summary(pixel_rv(images, ref))
    r = len(images)
    subs = [summary(pixel_rv(np.delete(images, k, axis=0), ref)) for k in range(r)]
    se = {}
    for key in full:
        v = np.array([s[key] for s in subs])
        se[key] = float(np.sqrt((r - 1) / r * np.sum((v - v.mean()) ** 2)))
    return full, se


def ratio_se(a: float, a_se: float, b: float, b_se: float) -> float:
    """Standard error of a / b for independent a, b (first order)."""
    return abs(a / b) * float(np.hypot(a_se / a, b_se / b)) if a > 0 and b > 0 else float("nan")


def compare(mc: np.ndarray, mts: np.ndarray) -> dict:
    """The module doc's figures for mcpt's runs ``mc`` against Mitsuba's ``mts`` (both (R, H, W, 3))."""
    ref = mts.mean(axis=0)
    m, m_se = jackknife(mc, ref)
    t, t_se = jackknife(mts, ref)
    return {"mean_mcpt": float(mc.mean()), "mean_mitsuba": float(mts.mean()),
            "rv_mcpt": m["rv"], "rv_mcpt_se": m_se["rv"], "rv_mitsuba": t["rv"], "rv_mitsuba_se": t_se["rv"],
            "rv_trim_mcpt": m["rv_trim"], "rv_trim_mcpt_se": m_se["rv_trim"],
            "ratio": m["rv"] / t["rv"], "ratio_se": ratio_se(m["rv"], m_se["rv"], t["rv"], t_se["rv"]),
            "ratio_trim": m["rv_trim"] / t["rv_trim"],
            "ratio_trim_se": ratio_se(m["rv_trim"], m_se["rv_trim"], t["rv_trim"], t_se["rv_trim"]),
            "top1_share_mcpt": m["top1_share"], "top1_share_mcpt_se": m_se["top1_share"],
            "top1_share_mitsuba": t["top1_share"], "top1_share_mitsuba_se": t_se["top1_share"]}


def load_or_render_mitsuba(cache: Path | None, scene: Path, a, tmp: Path) -> np.ndarray:
    if cache is not None and cache.exists():
        data = np.load(cache)
        if int(data["spp"]) == a.spp and len(data["images"]) == a.runs and str(data["resolution"]) == a.resolution:
            return data["images"]
        print(f"{cache}: other settings, rendering again", file=sys.stderr)
    images = mitsuba_runs(scene, a.spp, a.runs, a.resolution, tmp)
    if cache is not None:
        np.savez(cache, images=images, spp=a.spp, resolution=a.resolution)
    return images


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m mcpt.bench.plastic_variance", description=__doc__.split("\n")[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--runs", type=int, default=8)
    ap.add_argument("--resolution", default="96x72")
    ap.add_argument("--samplers", default="independent,sobol")
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--mitsuba-cache", type=Path, default=None)
    ap.add_argument("--json", type=Path, default=None)
    a = ap.parse_args(argv)
    if a.runs < 3:
        ap.error("--runs must be >= 3 (a variance and its jackknife)")
    tmp = Path(tempfile.mkdtemp(prefix="mcpt_plastic_var_"))
    mts = load_or_render_mitsuba(a.mitsuba_cache, a.scene, a, tmp)
    rows = {}
    print(f"{a.scene.name}: {a.resolution}, {a.spp} spp, {a.runs} runs a side (+- jackknife s.e.)")
    print(f"{'mcpt sampler':14s} {'ratio':>14s} {'ratio w/o top1%':>16s} {'top1% share mcpt':>17s} {'Mitsuba':>14s}"
          f" {'mcpt s/run':>10s}")
    for sampler in a.samplers.split(","):
        mc, seconds = mcpt_runs(a.scene, a.spp, a.runs, a.seed, sampler, a.resolution, tmp)
        np.save(tmp / f"mcpt_{sampler}.npy", mc)  # kept for a look at where the noise is
        r = rows[sampler] = {**compare(mc, mts), "mcpt_render_seconds": seconds}
        print(f"{sampler:14s} {r['ratio']:6.3f} +- {r['ratio_se']:5.3f}"
              f" {r['ratio_trim']:7.3f} +- {r['ratio_trim_se']:5.3f}"
              f" {r['top1_share_mcpt']:8.3f} +- {r['top1_share_mcpt_se']:5.3f}"
              f" {r['top1_share_mitsuba']:5.3f} +- {r['top1_share_mitsuba_se']:5.3f} {seconds:10.2f}", flush=True)
    print(f"images: {tmp}", file=sys.stderr)
    if a.json:
        a.json.write_text(json.dumps({"scene": str(a.scene), "spp": a.spp, "runs": a.runs,
                                      "resolution": a.resolution, "samplers": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

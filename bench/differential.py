"""The differential harness (issue #19): one Mitsuba 3 XML scene rendered by mcpt and by Mitsuba 3,
compared with statistics that know each side's noise.

    python -m mcpt.bench.differential SCENE.xml [SCENE.xml ...] --spp N [-D name=value] [--json F]
                                      [--list FILE] [--resolution WxH]

``--list FILE`` adds the scene paths a text file names (one a line; ``#`` starts a comment;
``$VARIABLES`` expanded; relative paths are relative to FILE's folder), e.g. published scenes kept
outside the repository (bench/published-scenes.txt: ``$MCPT_PUBLISHED_SCENES/...``).
``--resolution WxH`` renders both sides at that film size (mcpt's ``--resolution``; Mitsuba's
films resized through ``mi.parser``, bench/mitsuba_xml.py), for scenes whose size is no
``<default>``. A scene mcpt refuses is a row ``refused`` with mcpt's one-line message (the
harness checks it is one line); a scene Mitsuba fails on is a row ``peer failed``.

mcpt renders through its CLI (``mcpt render SCENE.xml --aov variance``: the variance of each
pixel's mean from its own samples); Mitsuba renders in the peer venv (bench/mitsuba_xml.py,
``make peer-setup``) as ``--runs`` independent renders whose spread gives the variance of its mean.
Reported per scene:

* ``mean_z``: (mean_mcpt - mean_mitsuba) / sigma of that difference, over all pixels and channels
  (pixels are independent, so the variances add). |z| < 3 means the images agree within noise.
* ``pixel_z``: the fraction of pixel channels with |z| > 3 in a per-pixel test
  ((a - b) / sqrt(var_a + var_b)); about 0.3 % for agreeing Gaussian estimates (more at very low
  spp, where the variance estimates themselves are noisy).
* ``relmse``: relMSE between the two images (bench/common.py: eps 0.01), and ``relmse_noise``:
  what the two variances alone predict for it (agreeing renderers: relmse ~ relmse_noise).
* ``Sidak``: bench/stats.py's z-test, Mitsuba 3's own rule for its render tests: pass when at
  least 99.75 % of the pixel channels are within the Šidák-corrected |z| threshold (image alpha
  0.01) and every channel's image mean within 4 standard errors; the column gives the share
  accepted.
* ``seconds``: each renderer's render time (mcpt: its render loop; Mitsuba: its ``mi.render``
  calls; process start, parsing and BVH builds excluded on both sides).

Both sides read the same file with the same ``-D`` parameters and the same ``spp``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from . import mitsuba as peer
from . import stats

ROOT = Path(__file__).resolve().parent.parent
SCENES = Path(__file__).resolve().parent / "scenes-xml"


class Refused(Exception):
    """mcpt refused the scene (exit 2) with the one located line this carries."""


def run_mcpt(scene: Path, spp: int, seed: int, defines: list[str], tmp: Path,
             resolution: str | None = None) -> dict:
    from mcpt.output.image import read_exr_channels

    out = tmp / "mcpt.exr"
    cmd = [sys.executable, "-m", "mcpt", "render", str(scene), "--spp", str(spp), "--seed", str(seed),
           "--aov", "variance", "-o", str(out), "--json", "--progress", "none",
           *(x for d in defines for x in ("-D", d)),
           *(("--resolution", resolution) if resolution else ())]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode == 2:
        lines = [ln for ln in res.stderr.splitlines() if ln.startswith("mcpt: error:")]
        if len(lines) != 1:
            raise RuntimeError(f"mcpt refused without one located line: {res.stderr.strip()[-600:]}")
        raise Refused(lines[0].removeprefix("mcpt: error:").strip())
    if res.returncode != 0:
        raise RuntimeError(f"mcpt failed: {res.stderr.strip()[-600:]}")
    meta = json.loads(res.stdout)
    ch = read_exr_channels(out)
    mean = np.stack([ch[c] for c in "RGB"], -1).astype(np.float64)
    var = np.stack([ch[f"variance.{c}"] for c in "RGB"], -1).astype(np.float64)
    warnings = [ln for ln in res.stderr.splitlines() if "warning" in ln]
    return {"mean": mean, "var_mean": var, "seconds": meta["render_seconds"], "warnings": warnings}


def run_mitsuba(scene: Path, spp: int, seed: int, defines: list[str], runs: int, tmp: Path,
                resolution: str | None = None) -> dict:
    out = tmp / "mitsuba.npz"
    cmd = [str(peer.python()), str(Path(__file__).with_name("mitsuba_xml.py")), str(scene), str(out),
           "--spp", str(spp), "--runs", str(runs), "--seed", str(seed), "--tool", str(peer.tool()),
           *(x for d in defines for x in ("-D", d)),
           *(("--resolution", resolution) if resolution else ())]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError(f"Mitsuba failed: {(res.stderr.strip() or res.stdout.strip())[-600:]}")
    info = peer.parse_output(res.stdout)
    data = np.load(out)
    return {"mean": data["mean"], "var_mean": data["var_mean"], "seconds": info["render_seconds"],
            "spp": info["spp"], "version": info["mitsuba_version"]}


def compare(a: dict, b: dict, eps: float = 0.01, spp: int | None = None) -> dict:
    """The statistics of the module doc for two (mean, var_mean) images of the same shape; with
    ``spp``, also bench/stats.py's Šidák-corrected per-pixel z-test (Mitsuba 3's render-test rule),
    its variance floor being the per-sample floor of that module over ``spp``."""
    x, y = a["mean"], b["mean"]
    if x.shape != y.shape:
        raise ValueError(f"image shapes differ: mcpt {x.shape}, Mitsuba {y.shape}")
    var = a["var_mean"] + b["var_mean"]
    n = x.size
    diff = float(x.mean() - y.mean())
    sigma = math.sqrt(float(var.sum())) / n
    ok = var > 0
    z = np.zeros_like(x)
    z[ok] = (x - y)[ok] / np.sqrt(var[ok])
    ref = y
    return {"mean_mcpt": float(x.mean()), "mean_mitsuba": float(y.mean()),
            "mean_z": diff / sigma if sigma > 0 else float("nan"),
            "pixel_z_gt3": float((np.abs(z) > 3).mean()),
            "relmse": float(np.mean((x - y) ** 2 / (ref * ref + eps))),
            "relmse_noise": float(np.mean(var / (ref * ref + eps))), **_sidak(a, b, spp)}


def _sidak(a: dict, b: dict, spp: int | None) -> dict:
    if spp is None:
        return {}
    y = b["mean"]
    t = stats.z_test(a["mean"], y, a["var_mean"], b["var_mean"],
                     var_floor=(stats.VAR_FLOOR_ABS + stats.VAR_FLOOR_REL * y * y) / spp)
    return {"sidak_pass": bool(t.passed), "sidak_accepted": t.accepted, "sidak_threshold": t.threshold,
            "sidak_global_z": [float(v) for v in np.atleast_1d(t.global_z)]}


def read_list(path: Path) -> list[Path]:
    """The scene paths ``path`` names: one a line, ``#`` comments, relative to its folder."""
    out = []
    for line in path.read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            p = Path(os.path.expandvars(line)).expanduser()
            out.append((p if p.is_absolute() else path.parent / p).resolve())
    return out


def measure(scene: Path, a) -> dict:
    """One scene's row: the figures, or ``status`` refused / peer failed with the one line why."""
    row: dict = {"scene": str(scene), "spp": a.spp, "resolution": a.resolution}
    with tempfile.TemporaryDirectory() as tmp:
        try:
            m = run_mcpt(scene, a.spp, a.seed, a.defines, Path(tmp), a.resolution)
        except Refused as exc:
            return {**row, "status": "refused", "why": str(exc)}
        try:
            p = run_mitsuba(scene, a.spp, a.seed + 1, a.defines, a.runs, Path(tmp), a.resolution)
        except RuntimeError as exc:
            return {**row, "status": "peer failed", "why": str(exc).splitlines()[-1]}
    return {**row, "status": "rendered", **compare(m, p, spp=a.spp), "seconds_mcpt": m["seconds"],
            "seconds_mitsuba": p["seconds"], "mitsuba": p["version"], "warnings": m["warnings"]}


def short(scene: Path, width: int = 34) -> str:
    """The last path components of ``scene`` that fit ``width`` characters."""
    parts, name = scene.parts, scene.name
    for k in range(2, len(parts) + 1):
        cand = "/".join(parts[-k:])
        if len(cand) > width:
            break
        name = cand
    return name


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="*", type=Path, help=f"XML scenes (default: every {SCENES}/*.xml)")
    ap.add_argument("--list", type=Path, action="append", default=[], metavar="FILE",
                    help="a text file of scene paths, one a line (# comments)")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--runs", type=int, default=4, help="Mitsuba renders whose spread gives its variance")
    ap.add_argument("--resolution", default=None, metavar="WxH", help="both sides' film size")
    ap.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--json", type=Path, default=None, help="write the figures as JSON too")
    a = ap.parse_args(argv)
    avail = peer.available()
    if not avail.ok:
        print(f"differential: Mitsuba unavailable: {avail.reason}", file=sys.stderr)
        return 2
    scenes = list(a.scenes) + [p for f in a.list for p in read_list(f)]
    scenes = scenes or sorted(SCENES.glob("*.xml"))
    rows = []
    print(f"{'scene':34s} {'mean mcpt':>10s} {'mean mts':>10s} {'z':>6s} {'|z|>3':>7s} "
          f"{'relMSE':>9s} {'noise':>9s} {'t mcpt':>7s} {'t mts':>7s} {'Sidak':>13s}")
    for scene in scenes:
        row = measure(scene, a)
        rows.append(row)
        if row["status"] != "rendered":
            print(f"{short(scene):34s} {row['status']}: {row['why']}")
            continue
        print(f"{short(scene):34s} {row['mean_mcpt']:10.4f} {row['mean_mitsuba']:10.4f} "
              f"{row['mean_z']:6.2f} {100 * row['pixel_z_gt3']:6.2f}% {row['relmse']:9.2e} "
              f"{row['relmse_noise']:9.2e} {row['seconds_mcpt']:7.2f} {row['seconds_mitsuba']:7.2f} "
              f"{'pass' if row['sidak_pass'] else 'FAIL'} {100 * row['sidak_accepted']:6.2f}%")
        for w in row["warnings"]:
            print(f"    {w}")
    if a.json is not None:
        a.json.write_text(json.dumps(rows, indent=2))
    rendered = [r for r in rows if r["status"] == "rendered"]
    failed = [r for r in rows if r["status"] == "peer failed"]
    return 0 if not failed and all(abs(r["mean_z"]) < 3 for r in rendered) else 1


if __name__ == "__main__":
    raise SystemExit(main())

"""mcpt and Mitsuba 3 side by side on environment-lit scenes with a sun (issue #20's speed target:
relMSE at equal spp no worse than 1.2x Mitsuba's, time to relMSE 1e-2 no longer than Mitsuba's).

    MCPT_PEER_PYTHON=/work/main/.venv-peer/bin/python \\
        python -m mcpt.bench.envmap_peer [SCENE.xml ...] --spp 4 16 64 256 --rounds 2

Each scene is a Mitsuba XML file of bench/scenes-xml/ (default: the envmap with a sun disk over
diffuse spheres, and the sky map plus a directional sun), read by both renderers. (The glass
sphere of lights-envmap-sun.xml makes caustics of the sun disk that only BSDF sampling finds:
fireflies that keep relMSE near 0.2-0.4 at 256 spp for both renderers and their reference, so
time to 1e-2 is never reached there.) Per round,
per spp, mcpt renders (in this process, the scene prepared and compiled once: bench/peer_run.py's
_Mcpt) and then Mitsuba (bench/mitsuba_xml.py in the peer venv, one ``mi.render``; a warm-up
render first, so its kernel compilation is not timed), alternating so both see the same load.
Seconds are each renderer's own render time (set-up excluded). relMSE (bench/common.py, eps
0.01) is against one Mitsuba render at ``--ref-spp`` (cached under out/bench/envmap_peer/). The
curves, the time to relMSE 1e-2 and the ratios at equal spp come from bench/peer.py's
summarize, the same functions as ``mcpt bench --only peer``.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from . import common, differential, mitsuba
from .peer import summarize, summary_lines
from .peer_run import _Mcpt

SCENES = differential.SCENES
DEFAULT_SCENES = ("lights-envmap-diffuse.xml", "lights-sky-sun.xml")
OUT = differential.ROOT / "out" / "bench" / "envmap_peer"


def reference(scene: Path, spp: int, tmp: Path) -> np.ndarray:
    """Mitsuba's image of ``scene`` at ``spp`` (cached by scene name, size and spp)."""
    cache = OUT / f"{scene.stem}-{scene.stat().st_size}-ref{spp}.npy"
    if cache.exists():
        return np.load(cache)
    img = differential.run_mitsuba(scene, spp, 987_654, [], 1, tmp)["mean"]
    cache.parent.mkdir(parents=True, exist_ok=True)
    np.save(cache, img)
    return img


def sweep(scene: Path, spps, rounds: int, ref_spp: int, seed: int, log) -> list[dict]:
    """The records (bench/peer.py's format) of both renderers on one scene."""
    records = []
    with tempfile.TemporaryDirectory() as t:
        tmp = Path(t)
        ref = reference(scene, ref_spp, tmp)
        res = ref.shape[0]
        mc = _Mcpt(scene, SimpleNamespace(seed=seed, gl_backend=None), res, "sobol")
        try:
            differential.run_mitsuba(scene, min(spps), seed, [], 1, tmp)  # warm-up (kernel cache)
            for r in range(rounds):
                for spp in spps:
                    s = seed + 1000 * r + spp
                    img, info = mc.run(spp, s, tmp)
                    records.append(_record(scene, "mcpt", mc.label, spp, img, ref, info["seconds"]))
                    m = differential.run_mitsuba(scene, spp, s, [], 1, tmp)
                    records.append(_record(scene, "mitsuba", f"Mitsuba {m['version']} llvm_ad_rgb",
                                           spp, m["mean"], ref, m["seconds"]))
                    log(f"  {scene.stem} round {r} {spp:4d} spp: mcpt {records[-2]['seconds']:.3f} s "
                        f"relMSE {records[-2]['relmse']:.3g} | Mitsuba {records[-1]['seconds']:.3f} s "
                        f"relMSE {records[-1]['relmse']:.3g}")
        finally:
            mc.close()
    return records


def _record(scene: Path, renderer: str, label: str, spp: int, img, ref, seconds: float) -> dict:
    paths = ref.shape[0] * ref.shape[1] * spp
    # No CPU seconds for the Mitsuba subprocess: the CPU fields repeat the wall ones (not printed).
    return {"scene": scene.stem, "renderer": renderer, "sampler": label.split()[-1] if renderer == "mcpt"
            else "independent", "label": label, "spp": spp, "seconds": seconds, "cpu_seconds": seconds,
            "paths_per_second": paths / seconds, "paths_per_cpu_second": paths / seconds,
            **common.errors(np.asarray(img, np.float64)[..., :3], ref)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="*", type=Path, help=f"XML scenes (default: {', '.join(DEFAULT_SCENES)})")
    ap.add_argument("--spp", type=int, nargs="+", default=[4, 16, 64, 256])
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--ref-spp", type=int, default=8192)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", type=Path, default=None, help="write the records and summary as JSON")
    a = ap.parse_args(argv)
    avail = mitsuba.available()
    if not avail.ok:
        print(f"envmap_peer: Mitsuba unavailable: {avail.reason}", file=sys.stderr)
        return 2
    records = []
    for scene in a.scenes or [SCENES / s for s in DEFAULT_SCENES]:
        records += sweep(scene, sorted(a.spp), a.rounds, a.ref_spp, a.seed, lambda s: print(s, flush=True))
    summary = summarize(records, thresholds=(1e-2,))
    print("\n".join(summary_lines(summary)))
    if a.json is not None:
        common.write_json(a.json, {"records": records, **summary})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

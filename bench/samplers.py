"""Sobol' against independent numbers, measured side by side (issue #14 part 3).

``python -m bench.samplers [--rounds N] [--spp 64] [--resolution 256]``: renders
scenes/cornell-box.yaml (8 bounces) with both samplers alternating (A, B, A, B, ...) in one
process, and prints per round paths/s, host seconds per pass spent making random numbers, and
relMSE against the Mitsuba 3 reference (../shared/scenes-ref/cornell/reference.exr); then an
error-vs-spp sweep per sampler with the fitted slope of log relMSE against log spp.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from mcpt.api import prepare
from mcpt.image import read_exr

from . import common, scenes


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--resolution", type=int, default=256)
    ap.add_argument("--sweep", default="4,16,64,256", help="spp list of the error sweep ('' = none)")
    ap.add_argument("--json", default=None, help="write the records here")
    a = ap.parse_args(argv)
    n = a.resolution
    ref, _ = read_exr(scenes.cornell_reference())
    ref = common.downsample(np.asarray(ref, np.float32)[..., :3], n, n)
    scene = common.ROOT / "scenes" / "cornell-box.yaml"
    samplers = ("sobol", "independent")
    ps = {s: prepare(scene, resolution=(n, n), bounces=8, sampler=s) for s in samplers}
    for s in samplers:  # warm-up: JIT and first-touch allocations outside the timing
        ps[s].renderer.render(1, seed=0)
    rec = {"rounds": [], "sweep": {}}
    for r in range(a.rounds):
        for s in samplers:
            res = ps[s].renderer.render(a.spp, seed=100 + r)
            row = {"round": r, "sampler": s, "spp": a.spp,
                   "paths_per_second": res.paths_per_second,
                   "render_seconds": res.render_seconds,
                   "host_random_seconds_per_pass": res.random_seconds / a.spp,
                   "relmse": common.relmse(res.image, ref), "dropped": res.dropped_samples}
            rec["rounds"].append(row)
            print(f"round {r} {s:11s} {row['paths_per_second'] / 1e6:6.3f} Mpaths/s  "
                  f"host random {1e3 * row['host_random_seconds_per_pass']:6.2f} ms/pass  "
                  f"relMSE {row['relmse']:.4e}", flush=True)
    for s in samplers:
        rows = [x for x in rec["rounds"] if x["sampler"] == s]
        print(f"mean {s:11s} {np.mean([x['paths_per_second'] for x in rows]) / 1e6:6.3f} Mpaths/s  "
              f"relMSE {np.mean([x['relmse'] for x in rows]):.4e}")
    by = {s: [x for x in rec["rounds"] if x["sampler"] == s] for s in samplers}
    ratio = np.mean([a_["paths_per_second"] / b_["paths_per_second"] for a_, b_ in zip(by["sobol"], by["independent"])])
    rel = np.mean([a_["relmse"] / b_["relmse"] for a_, b_ in zip(by["sobol"], by["independent"])])
    print(f"sobol / independent: paths/s x{ratio:.3f}, relMSE at equal spp x{rel:.3f}, "
          f"time to equal error x{rel / ratio:.3f}")
    sweep = [int(x) for x in a.sweep.split(",") if x]
    for s in samplers if sweep else ():
        errs, secs = [], []
        for spp in sweep:
            res = ps[s].renderer.render(spp, seed=7)
            errs.append(common.relmse(res.image, ref))
            secs.append(res.render_seconds)
        slope = float(np.polyfit(np.log(sweep), np.log(errs), 1)[0])
        rec["sweep"][s] = {"spp": sweep, "relmse": errs, "seconds": secs, "slope": slope}
        print(f"sweep {s:11s} spp {sweep} relMSE {[f'{e:.3e}' for e in errs]} slope {slope:.3f}")
    for p in ps.values():
        p.renderer.release()
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rec, f, indent=1)
    return rec


if __name__ == "__main__":
    main()

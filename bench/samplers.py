"""Sobol' against independent numbers, measured side by side (issue #14 part 3).

``python -m bench.samplers [--rounds N] [--spp 64] [--resolution 256] [--baseline DIR]``:
renders scenes/cornell-box.yaml (8 bounces) with both samplers, with sobol taking 1 or 4 samples
per draw instead of features.samples_per_draw (64 at 256x256; ``sobol-1spd``, ``sobol-4spd``: path
regeneration, 4 was the default before) and without path
continuation (``sobol-nocont``; the same program as ``sobol`` on this scene, whose paths cannot
need continuing, see features.needs_continuation), alternating (A, B, C, ...) in one process
(``--variants`` picks some), and prints per
round paths/s, host seconds per pass spent making random numbers, and relMSE against the
Mitsuba 3 reference (../shared/scenes-ref/cornell/reference.exr); then an error-vs-spp sweep per
sampler with the fitted slope of log relMSE against log spp. ``--baseline DIR`` adds another
checkout of mcpt (its .venv) as one more side of the alternation, rendered in a subprocess
(render time only, as the others).
"""

from __future__ import annotations

import argparse
import json
import subprocess
from pathlib import Path

import numpy as np

from mcpt.api import Options, prepare, run
from mcpt.output.image import read_exr

from . import common, scenes


def _draw(p, spp: int, seed: int):
    """``spp`` passes of ``seed`` of the prepared scene ``p`` (the library's render loop)."""
    return run(p, Options(spp=spp, seed=seed)).result


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--resolution", type=int, default=256)
    ap.add_argument("--sweep", default="4,16,64,256", help="spp list of the error sweep ('' = none)")
    ap.add_argument("--json", default=None, help="write the records here")
    ap.add_argument("--baseline", default=None, help="another mcpt checkout to alternate with")
    ap.add_argument("--variants", default="", help="comma-separated subset of the sides")
    a = ap.parse_args(argv)
    n = a.resolution
    ref, _ = read_exr(scenes.cornell_reference())
    ref = common.downsample(np.asarray(ref, np.float32)[..., :3], n, n)
    scene = common.ROOT / "scenes" / "cornell-box.yaml"
    samplers = ("sobol", "independent")
    # name: (prepare() arguments, samples per draw: None the renderer's own)
    variants = {"sobol": ({"sampler": "sobol"}, None),
                "independent": ({"sampler": "independent"}, None),
                "sobol-1spd": ({"sampler": "sobol"}, 1),
                "sobol-4spd": ({"sampler": "sobol"}, 4),
                "sobol-nocont": ({"sampler": "sobol", "feature_flags": {"continuation": False}}, None)}
    if a.variants:  # e.g. --variants sobol,independent,sobol-1spd
        variants = {k: v for k, v in variants.items() if k in a.variants.split(",")}
    ps = {s: prepare(scene, resolution=(n, n), bounces=8, **kw) for s, (kw, _) in variants.items()}
    for s, (_, spd) in variants.items():
        if spd is not None:  # path regeneration narrower than the image allows (sobol only)
            ps[s].renderer.samples_per_draw = spd
        _draw(ps[s], 1, 0)  # warm-up: JIT and first-touch allocations outside the timing
    sides = list(variants) + (["baseline"] if a.baseline else [])
    rec = {"rounds": [], "sweep": {}}
    for r in range(a.rounds):
        for s in sides:
            if s == "baseline":
                got = _baseline(a.baseline, scene, n, a.spp, 100 + r)
                row = {"round": r, "sampler": s, "spp": a.spp, **got,
                       "relmse": common.relmse(np.load(got.pop("image_file")), ref)}
            else:
                res = _draw(ps[s], a.spp, 100 + r)
                row = {"round": r, "sampler": s, "spp": a.spp,
                       "paths_per_second": res.paths_per_second,
                       "render_seconds": res.render_seconds,
                       "host_random_seconds_per_pass": res.random_seconds / a.spp,
                       "relmse": common.relmse(res.image, ref), "dropped": res.dropped_samples}
            rec["rounds"].append(row)
            print(f"round {r} {s:11s} {row['paths_per_second'] / 1e6:6.3f} Mpaths/s  "
                  f"host random {1e3 * row['host_random_seconds_per_pass']:6.2f} ms/pass  "
                  f"relMSE {row['relmse']:.4e}", flush=True)
    for s in sides:
        rows = [x for x in rec["rounds"] if x["sampler"] == s]
        print(f"mean {s:11s} {np.mean([x['paths_per_second'] for x in rows]) / 1e6:6.3f} Mpaths/s  "
              f"relMSE {np.mean([x['relmse'] for x in rows]):.4e}")
    by = {s: [x for x in rec["rounds"] if x["sampler"] == s] for s in sides}
    for other in sides[1:]:
        ratio = np.mean([a_["paths_per_second"] / b_["paths_per_second"]
                         for a_, b_ in zip(by["sobol"], by[other])])
        rel = np.mean([a_["relmse"] / b_["relmse"] for a_, b_ in zip(by["sobol"], by[other])])
        print(f"sobol / {other}: paths/s x{ratio:.3f}, relMSE at equal spp x{rel:.3f}, "
              f"time to equal error x{rel / ratio:.3f}")
    sweep = [int(x) for x in a.sweep.split(",") if x]
    for s in samplers if sweep else ():
        errs, secs = [], []
        for spp in sweep:
            res = _draw(ps[s], spp, 7)
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


_BASELINE = """
import json, sys, numpy as np
from mcpt.api import prepare
scene, n, spp, seed, out = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
p = prepare(scene, resolution=(n, n), bounces=8)
try:  # the render loop of this version; a checkout from before it had Renderer.render
    from mcpt.api import Options, run
    draw = lambda spp, seed: run(p, Options(spp=spp, seed=seed)).result
except ImportError:
    draw = p.renderer.render
draw(1, 0)
res = draw(spp, seed)
np.save(out, res.image)
print(json.dumps({"paths_per_second": res.paths_per_second, "render_seconds": res.render_seconds,
                  "host_random_seconds_per_pass": res.random_seconds / spp,
                  "dropped": res.dropped_samples}))
"""


def _baseline(root: str, scene: Path, n: int, spp: int, seed: int) -> dict:
    """Render with another checkout (its own venv) in a subprocess; its render time only."""
    import tempfile

    out = Path(tempfile.mkdtemp()) / "baseline.npy"
    py = Path(root) / ".venv" / "bin" / "python"
    got = subprocess.run([str(py), "-c", _BASELINE, str(scene), str(n), str(spp), str(seed), str(out)],
                         cwd=root, check=True, capture_output=True, text=True)
    return {**json.loads(got.stdout.strip().splitlines()[-1]), "image_file": str(out)}


if __name__ == "__main__":
    main()

"""Denoising (issue #12): relMSE of the raw and the OIDN-denoised beauty against the Mitsuba 3
reference, and the denoiser's time.

    .venv/bin/python -m mcpt.bench.denoise                      # the README's table
    .venv/bin/python -m mcpt.bench.denoise --spp 4,16 --seeds 1 --scenes cornell

For each shared reference scene (``../shared/scenes-ref/<scene>``: scene.json converted to YAML
by bench/ab.py, reference.exr area-averaged to the resolution) and each spp, ``--seeds`` renders
with the albedo and normal AOVs; relMSE (bench/common.py, the peer study's definition) of the raw
image and of ``mcpt.output.denoise.denoise(image, albedo, normal)`` is averaged over the seeds.
Denoised figures are BIASED (a learned filter): they are not estimates that converge to the
reference as spp grows, only images closer to it.

Variance AOV: its agreement with the spread of renders with different seeds, per sampler.

Denoiser time: ``denoise()`` on a render of the Cornell box at each ``--time-res`` (1 spp: the
content barely matters to OIDN), the first call (filter set-up) and the median of ``--repeat``
further calls, wall seconds on this machine's CPU (OIDN's CPU device, all cores).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from . import common
from . import scenes as bench_scenes

SCENES = {"cornell": "cornell", "sphere100k": "cornell-sphere-100k"}


def parse(argv=None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="python -m mcpt.bench.denoise", description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default="cornell,sphere100k", help=f"of {', '.join(SCENES)}")
    ap.add_argument("--spp", default="4,16,64")
    ap.add_argument("--seeds", type=int, default=3, help="renders averaged per (scene, spp)")
    ap.add_argument("--resolution", type=int, default=256, help="square; the references are 256")
    ap.add_argument("--time-res", default="256x256,1920x1080")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--variance-seeds", type=int, default=16,
                    help="renders for the variance-AOV check (Cornell box 32x32; 0: skip)")
    ap.add_argument("--variance-spp", type=int, default=16)
    ap.add_argument("--gl-backend", default=None)
    ap.add_argument("-o", "--out", type=Path, default=Path("out/bench/denoise.json"))
    return ap.parse_args(argv)


def _render(path, res, spp, seed, gl_backend):
    from mcpt.api import Options, prepare, run

    p = prepare(path, resolution=res, gl_backend=gl_backend, aovs=("albedo", "normal"))
    try:
        return run(p, Options(spp=spp, seed=seed)).result
    finally:
        p.renderer.release()


def error_table(args, folder: Path) -> list[dict]:
    from mcpt.output.denoise import denoise
    from mcpt.output.image import read_exr

    rows = []
    res = args.resolution
    for name in args.scenes.split(","):
        d = bench_scenes.shared_dir() / "scenes-ref" / SCENES[name]
        ref = common.downsample(np.asarray(read_exr(d / "reference.exr")[0], np.float32)[..., :3], res, res)
        path = bench_scenes.write(bench_scenes.ref_scene_yaml(d), folder)
        for spp in (int(s) for s in args.spp.split(",")):
            raw, den, secs = [], [], []
            for seed in range(args.seeds):
                r = _render(path, (res, res), spp, seed, args.gl_backend)
                t0 = time.perf_counter()
                out = denoise(r.image, r.aovs["albedo"], r.aovs["normal"])
                secs.append(time.perf_counter() - t0)
                raw.append(common.relmse(r.image, ref))
                den.append(common.relmse(out, ref))
            row = {"scene": name, "spp": spp, "seeds": args.seeds, "relmse_raw": float(np.mean(raw)),
                   "relmse_denoised_biased": float(np.mean(den)),
                   "gain": float(np.mean(raw) / np.mean(den)), "denoise_seconds": float(np.median(secs))}
            print(f"{name:10s} {spp:4d} spp  relMSE raw {row['relmse_raw']:.4g}  denoised (biased) "
                  f"{row['relmse_denoised_biased']:.4g}  ({row['gain']:.1f}x lower)", flush=True)
            rows.append(row)
    return rows


def time_table(args) -> list[dict]:
    from mcpt.output.denoise import denoise

    rows = []
    path = bench_scenes.CORNELL_YAML
    for text in args.time_res.split(","):
        w, h = (int(v) for v in text.lower().split("x"))
        r = _render(path, (w, h), 1, 0, args.gl_backend)
        t0 = time.perf_counter()
        denoise(r.image, r.aovs["albedo"], r.aovs["normal"])
        first = time.perf_counter() - t0
        runs = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            denoise(r.image, r.aovs["albedo"], r.aovs["normal"])
            runs.append(time.perf_counter() - t0)
        row = {"resolution": [w, h], "first_seconds": first, "median_seconds": statistics.median(runs),
               "runs": runs, "mpixels_per_second": w * h / statistics.median(runs) / 1e6}
        print(f"denoise {w}x{h}: first call {first:.3f} s, median of {args.repeat} "
              f"{row['median_seconds']:.3f} s ({row['mpixels_per_second']:.2f} Mpixel/s)", flush=True)
        rows.append(row)
    return rows


def variance_check(args) -> list[dict]:
    """The variance AOV (sample variance / spp, from one render) against the variance of the means
    of ``--variance-seeds`` renders with different seeds, per sampler: equal in expectation for
    independent numbers; Sobol' means vary less than that (the AOV is then an upper bound)."""
    from mcpt.api import Options, prepare, run

    rows = []
    for sampler in ("independent", "sobol"):
        means, reported = [], []
        for seed in range(args.variance_seeds):
            p = prepare(bench_scenes.CORNELL_YAML, resolution=(32, 32), gl_backend=args.gl_backend,
                        aovs=("variance",), sampler=sampler)
            try:
                r = run(p, Options(spp=args.variance_spp, seed=1000 + seed)).result
            finally:
                p.renderer.release()
            means.append(r.image.astype(np.float64))
            reported.append(r.variance.astype(np.float64))
        ratio = float(np.var(means, axis=0, ddof=1).sum() / np.mean(reported, axis=0).sum())
        print(f"variance {sampler:11s} {args.variance_spp} spp: spread of {args.variance_seeds} "
              f"renders / variance AOV = {ratio:.3f}", flush=True)
        rows.append({"sampler": sampler, "spp": args.variance_spp, "renders": args.variance_seeds,
                     "ratio": ratio})
    return rows


def main(argv=None) -> int:
    args = parse(argv)
    from mcpt.output.denoise import version

    meta = {**common.run_meta(argv=sys.argv), "denoiser": version()}
    with tempfile.TemporaryDirectory() as tmp:
        errors = error_table(args, Path(tmp)) if args.spp else []
    timing = time_table(args) if args.time_res else []
    variance = variance_check(args) if args.variance_seeds > 1 else []
    common.write_json(args.out, {"meta": meta, "errors": errors, "timing": timing, "variance": variance,
                                 "note": "denoised relMSE is biased (OIDN, a learned filter)"})
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

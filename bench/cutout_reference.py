"""The cut-out leaf (bench/scenes-xml/cutout.xml, Mitsuba's ``mask`` with a 0/1 checkerboard) in
mcpt against Mitsuba 3 rendering the same leaf as geometry (cutout-squares.xml: its opaque
squares as rectangles, no mask). Mitsuba's own mask render is unbiased but its shadow rays stop at
the mask (ray_test sees the geometry), so the light through the holes comes from BSDF sampling
alone, fireflies whose spread 4-16 runs do not estimate; the geometric leaf gives Mitsuba its
ordinary noise, and the comparison is that of bench/differential.py (mean z, pixels |z| > 3).

    python -m mcpt.bench.cutout_reference --spp 64
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from .differential import SCENES, compare, run_mcpt, run_mitsuba


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--runs", type=int, default=4)
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        m = run_mcpt(SCENES / "cutout.xml", a.spp, a.seed, [], Path(tmp))
        p = run_mitsuba(SCENES / "cutout-squares.xml", a.spp, a.seed + 1, [], a.runs, Path(tmp))
    row = compare(m, p)
    print(f"cutout.xml (mcpt) vs cutout-squares.xml (Mitsuba {p['version']}), {a.spp} spp: "
          f"mean {row['mean_mcpt']:.4f} / {row['mean_mitsuba']:.4f}, z {row['mean_z']:.2f}, "
          f"pixels |z|>3 {100 * row['pixel_z_gt3']:.2f} %, relMSE {row['relmse']:.2e} "
          f"(noise {row['relmse_noise']:.2e}), s {m['seconds']:.2f} / {p['seconds']:.2f}")
    return 0 if abs(row["mean_z"]) < 3 else 1


if __name__ == "__main__":
    raise SystemExit(main())

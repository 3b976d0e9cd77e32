"""Environment map table build time (mcpt/shading/envmap.py build_envmap) and packing time for a
synthetic HDR map: a smooth sky, a sun of 10^5 over a few texels, and noise, so that no row and no
CDF is trivial. Wall and CPU seconds, median of ``--rounds``.

    .venv/bin/python -m mcpt.bench.envmap_build --width 2048 --height 1024 --rounds 5
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def synthetic_map(width: int, height: int) -> np.ndarray:
    rng = np.random.default_rng(0)
    y, x = np.mgrid[0:height, 0:width].astype(np.float32)
    sky = np.stack([0.3 + 0.2 * np.cos(y / height * np.pi), 0.5 + 0.0 * x, 0.9 + 0.1 * np.sin(x / width * 6.28)], -1)
    img = (sky * (1.0 + 0.1 * rng.random((height, width, 1), dtype=np.float32))).astype(np.float32)
    img[height // 5: height // 5 + 3, width // 3: width // 3 + 3] = 1e5
    return img


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--width", type=int, default=2048)
    ap.add_argument("--height", type=int, default=1024)
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args(argv)

    from mcpt.shading.envmap import build_envmap

    img = synthetic_map(args.width, args.height)
    rot = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
    times = {"build": [], "build CPU": [], "pack": []}
    for _ in range(args.rounds):
        c0, w0 = time.process_time(), time.perf_counter()
        env = build_envmap(img, scale=2.0, to_world=rot)
        times["build"].append(time.perf_counter() - w0)
        times["build CPU"].append(time.process_time() - c0)
        w0 = time.perf_counter()
        packed = env.pack()
        times["pack"].append(time.perf_counter() - w0)
    mib = sum(a.nbytes for a in packed.values()) / 2**20
    print(f"envmap {args.width} x {args.height}: build {np.median(times['build']):.3f} s wall "
          f"(min {min(times['build']):.3f}, CPU {np.median(times['build CPU']):.3f}), "
          f"pack {np.median(times['pack']):.3f} s, {mib:.1f} MiB of buffers; median of {args.rounds}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

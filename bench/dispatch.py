"""The dispatches of the path tracer side by side (issue #23: ``MCPT_DISPATCH`` fragment, compute,
wavefront): each scene prepared once per dispatch in one process, then rendered in turn, the
order alternating by round, and every round's images compared bit for bit.

    python -m mcpt.bench.dispatch --scenes sphere100k,bunny,cornell --spp 8 --rounds 3

Paths per CPU-second (the process's CPU time, llvmpipe's threads included: steadier than the
wall clock on a shared machine) and per wall second, each dispatch over the first one's.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from mcpt.api import Options, prepare, run
from mcpt.gpu.options import DISPATCHES, dispatch_flags

from .ab import scene_path
from .common import alternate


def compare(scene: Path, modes, *, spp: int, rounds: int, resolution) -> dict:
    """Per dispatch: CPU and wall seconds; ``same_bits``: every round's images equal across them."""
    prepared = {m: prepare(scene, resolution=resolution, cache=False,
                           feature_flags=dispatch_flags({"MCPT_DISPATCH": m})) for m in modes}
    try:
        for p in prepared.values():
            run(p, Options(spp=1, seed=0))  # compile and warm up
        cpu, wall, images = alternate(list(modes), lambda m, k: run(
            prepared[m], Options(spp=spp, seed=k)).result.image, rounds)
    finally:
        for p in prepared.values():
            p.renderer.release()
    same = all(np.array_equal(r[modes[0]].view(np.uint32), r[m].view(np.uint32)) for r in images for m in modes)
    return {"cpu_s": cpu, "wall_s": wall, "same_bits": same,
            "paths": rounds * spp * resolution[0] * resolution[1]}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", default="sphere100k,bunny,cornell")
    ap.add_argument("--modes", default=",".join(DISPATCHES), help="dispatches, the first is the base")
    ap.add_argument("--spp", type=int, default=8)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--resolution", type=int, nargs=2, default=(256, 256))
    args = ap.parse_args(argv)
    modes = args.modes.split(",")
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.scenes.split(","):
            r = compare(scene_path(name, Path(tmp)), modes, spp=args.spp, rounds=args.rounds,
                        resolution=tuple(args.resolution))
            base = modes[0]
            cells = [f"{m} {r['paths'] / r['cpu_s'][m] / 1e6:.3f} M/CPU-s "
                     f"({r['cpu_s'][base] / r['cpu_s'][m]:.2f}x, wall {r['wall_s'][base] / r['wall_s'][m]:.2f}x)"
                     for m in modes]
            print(f"{name:12s} " + "  ".join(cells) + f"  same bits: {r['same_bits']}", flush=True)


if __name__ == "__main__":
    main()

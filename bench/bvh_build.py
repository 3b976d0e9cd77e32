"""BVH build time and tree quality: this tree's builder (mcpt/shapes/bvh_build.py) against the
one at a git revision: its mcpt/shapes/bvh_build.py (run with this tree's other modules), or, at a
revision from before the package layout of issue #9, its single mcpt/bvh.py.

Both builders run in this process, alternating (A, B, A, B, ...), on the same triangles: wall
and CPU seconds (CPU time is less disturbed by other processes on a shared machine), and each
tree's SAH cost (mcpt/bvh.py BVH.sah_cost, loop iterations per ray entering the root box).

    .venv/bin/python -m mcpt.bench.bvh_build --base f2c0b3b --triangles 1000000 --rounds 3
    .venv/bin/python -m mcpt.bench.bvh_build --base main --npy tris.npy --rounds 5   # saved (F, 3, 3)
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def load_base(rev: str):
    """The builder at ``rev``: mcpt/shapes/bvh_build.py as a module of this tree's mcpt.shapes
    (its relative imports resolve to this tree), else mcpt/bvh.py stand-alone (numpy only)."""
    path, name, package = "mcpt/shapes/bvh_build.py", "mcpt.shapes.bvh_build_base", "mcpt.shapes"
    shown = subprocess.run(["git", "-C", str(ROOT), "show", f"{rev}:{path}"], capture_output=True, text=True)
    if shown.returncode != 0:
        path, name, package = "mcpt/bvh.py", "bvh_base", None
        shown = subprocess.run(["git", "-C", str(ROOT), "show", f"{rev}:{path}"], check=True,
                               capture_output=True, text=True)
    spec = importlib.util.spec_from_loader(name, loader=None)
    mod = importlib.util.module_from_spec(spec)
    mod.__package__ = package
    sys.modules[name] = mod  # dataclasses look the module up by name
    exec(compile(shown.stdout, f"{rev}:{path}", "exec"), mod.__dict__)
    return mod


def triangles(kind: str, n: int) -> np.ndarray:
    rng = np.random.default_rng(0)
    if kind == "random":  # small triangles scattered in the unit cube: the cache's worst case
        return (rng.random((n, 1, 3)) + 0.01 * rng.random((n, 3, 3))).astype(np.float32)
    from mcpt.shapes.mesh import load_mesh

    from . import meshes, scenes
    path = meshes.subdivided_obj(scenes.models_dir() / "stanford-bunny.obj", 2, ROOT / "out" / "bench" / "cache")
    return load_mesh(path).triangles().astype(np.float32)[:n]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", default="HEAD")
    ap.add_argument("--triangles", type=int, default=1_000_000)
    ap.add_argument("--mesh", choices=("random", "bunny"), default="random",
                    help="random triangles, or the bunny subdivided twice (1.1M) cut to --triangles")
    ap.add_argument("--npy", help="triangles saved with np.save, (F, 3, 3); overrides --mesh/--triangles")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args(argv)

    from mcpt.shapes import bvh_build as new
    from mcpt.shapes.bvh import BVH
    old = load_base(args.base)
    tris = np.load(args.npy) if args.npy else triangles(args.mesh, args.triangles)
    sides = {"A": old.build_bvh, "B": new.build_bvh}
    wall = {"A": [], "B": []}
    cpu = {"A": [], "B": []}
    trees = {}
    for r in range(args.rounds):
        for side in ("A", "B") if r % 2 == 0 else ("B", "A"):
            c0, w0 = time.process_time(), time.perf_counter()
            trees[side] = sides[side](tris)
            cpu[side].append(time.process_time() - c0)
            wall[side].append(time.perf_counter() - w0)
    for side, name in (("A", args.base), ("B", "worktree")):
        t = trees[side]
        sah = BVH(t.nodes, t.order, t.depth, t.max_leaf, t.build_seconds).sah_cost()
        print(f"{side} {name:10s} {len(tris):,d} triangles: wall {min(wall[side]):.2f} s "
              f"(median {np.median(wall[side]):.2f}), CPU {min(cpu[side]):.2f} s "
              f"(median {np.median(cpu[side]):.2f}); nodes {t.num_nodes:,d}, depth {t.depth}, "
              f"SAH cost {sah:.2f}")
    print(f"B/A CPU time {np.median(cpu['B']) / np.median(cpu['A']):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""A/B throughput of two versions of mcpt, alternating in one run (issue #14).

Timings on this machine are noisy (2 shared cores, llvmpipe), so speed is only ever compared as a
ratio measured side by side: two worker processes -- one importing the tree at a git revision
(extracted with ``git archive``), one importing this working tree -- each prepare the same scene
once, then render ``--spp`` passes in turn, A, B, A, B, ..., ``--rounds`` times. Only one worker
renders at a time. The ratio is B/A of the summed render seconds, i.e. of paths/s.

    .venv/bin/python -m mcpt.bench.ab --base HEAD --scenes cornell,bunny,sphere100k --rounds 3 --spp 16

Scenes: ``cornell`` (scenes/cornell-box.yaml), ``bunny`` (bench/scenes.py: the Stanford bunny in the
Cornell box), ``bunny-metal`` (scenes/bunny-metal.yaml), ``sphere100k`` / ``sphere10k`` (the shared
reference folders ``../shared/scenes-ref/cornell-sphere-*``, converted to YAML), or a scene file.
All are rendered at ``--resolution`` (256x256) with ``--bounces`` (8). ``--cpu``: paths per CPU
second instead of per wall second (the CPU time of a worker process between its draw's start and
end; another process on the cores then slows a side far less than it does its wall clock).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

import numpy as np

from . import scenes as bench_scenes

ROOT = Path(__file__).resolve().parent.parent

# The worker: prepares the scene with the mcpt its PYTHONPATH names first (the base revision's
# tree for side A, the installed working tree for side B), then renders on request.
_WORKER = r"""
import json, sys
from mcpt.api import prepare
p = prepare(sys.argv[2], resolution=(int(sys.argv[3]), int(sys.argv[4])), bounces=int(sys.argv[5]),
            gl_backend="egl")
try:  # the render loop of this version; a revision from before it had Renderer.render
    from mcpt.api import Options, run
    draw = lambda spp, seed: run(p, Options(spp=spp, seed=seed)).result
except ImportError:
    draw = p.renderer.render
draw(1, 0)  # warm-up: first-draw costs out of the timing
print(json.dumps({"ready": True, "nodes": p.world.bvh.num_nodes, "bvh": p.features.bvh}), flush=True)
import time
for line in sys.stdin:
    spp, seed = (int(x) for x in line.split())
    c0 = time.process_time()  # all threads of the process: llvmpipe's too
    r = draw(spp, seed)
    print(json.dumps({"seconds": r.render_seconds, "cpu_seconds": time.process_time() - c0,
                      "paths": spp * r.image.shape[0] * r.image.shape[1],
                      "mean": float(r.image.mean())}), flush=True)
"""


def scene_path(name: str, out_dir: Path) -> Path:
    if name == "cornell":
        return bench_scenes.CORNELL_YAML
    if name == "bunny-metal":
        return bench_scenes.CORNELL_YAML.parent / "bunny-metal.yaml"
    if name == "bunny":
        return bench_scenes.write(bench_scenes.with_model("bunny", 0, out_dir / "cache"), out_dir)
    if name.startswith("sphere"):
        folder = bench_scenes.shared_dir() / "scenes-ref" / f"cornell-{name[:6]}-{name[6:]}"
        return bench_scenes.write(bench_scenes.ref_scene_yaml(folder), out_dir)
    return Path(name)


def extract(rev: str, dest: Path) -> Path:
    """The tree at ``rev`` (mcpt/ and glsl/ are all a worker needs) unpacked under ``dest``."""
    tar = dest / "base.tar"
    subprocess.run(["git", "-C", str(ROOT), "archive", "-o", str(tar), rev, "mcpt", "glsl"], check=True)
    with tarfile.open(tar) as t:
        t.extractall(dest / "tree")
    # Since the house (issue #9) the shaders are the package mcpt.glsl: put them where a plain
    # import finds them, so side A runs its own shaders, not the installed tree's.
    (dest / "tree" / "glsl").rename(dest / "tree" / "mcpt" / "glsl")
    return dest / "tree"


class Worker:
    def __init__(self, tree: Path, scene: Path, args):
        env = dict(os.environ)
        if tree is not None:
            env["PYTHONPATH"] = str(tree)
        self.proc = subprocess.Popen(
            [sys.executable, "-c", _WORKER, "-", str(scene), str(args.resolution[0]),
             str(args.resolution[1]), str(args.bounces)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env,
            cwd=str(tree if tree is not None else ROOT))
        self.info = self._read()

    def _read(self) -> dict:
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError("worker died")
        return json.loads(line)

    def render(self, spp: int, seed: int) -> dict:
        self.proc.stdin.write(f"{spp} {seed}\n")
        self.proc.stdin.flush()
        return self._read()

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait()


def compare(scene: Path, base_tree: Path, args) -> dict:
    a, b = Worker(base_tree, scene, args), Worker(None, scene, args)
    secs = {"A": [], "B": []}
    means = {"A": [], "B": []}
    paths = 0
    try:
        for r in range(args.rounds):
            for side, w in (("A", a), ("B", b)) if r % 2 == 0 else (("B", b), ("A", a)):
                out = w.render(args.spp, r)
                secs[side].append(out["cpu_seconds" if args.cpu else "seconds"])
                means[side].append(out["mean"])
                paths = out["paths"]
    finally:
        a.close(), b.close()
    pps = {k: paths * len(v) / sum(v) for k, v in secs.items()}
    return {"scene": str(scene), "paths_per_second": pps, "ratio_B_over_A": pps["B"] / pps["A"],
            "per_round_ratio": [sa / sb for sa, sb in zip(secs["A"], secs["B"])],
            "same_mean": means["A"] == means["B"], "mean": means}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", default="HEAD", help="git revision for side A (default HEAD)")
    ap.add_argument("--scenes", default="cornell,bunny,sphere100k")
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--spp", type=int, default=8, help="passes per turn")
    ap.add_argument("--bounces", type=int, default=8)
    ap.add_argument("--resolution", type=int, nargs=2, default=(256, 256))
    ap.add_argument("--cpu", action="store_true",
                    help="compare CPU seconds of the worker processes (llvmpipe's threads included), "
                         "not wall seconds: steadier where other work shares the cores (issue #23)")
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "bench" / "ab")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        base_tree = extract(args.base, Path(tmp))
        for name in args.scenes.split(","):
            res = compare(scene_path(name, args.out), base_tree, args)
            pps = res["paths_per_second"]
            print(f"{name:12s} A({args.base}) {pps['A'] / 1e6:.3f} M/s  B(worktree) {pps['B'] / 1e6:.3f} M/s"
                  f"  B/A {res['ratio_B_over_A']:.2f}  rounds "
                  + " ".join(f"{x:.2f}" for x in res["per_round_ratio"])
                  + f"  image mean A {np.mean(res['mean']['A']):.6f} B {np.mean(res['mean']['B']):.6f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

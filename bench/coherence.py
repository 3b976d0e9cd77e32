"""What ray coherence would buy on llvmpipe: an upper bound, measured (issue #23).

llvmpipe shades 8 pixels (two 2x2 quads, a 4x2 block) in one SIMD batch and runs the BVH
traversal loop while any of them needs it, so a batch pays for its slowest ray
(``lane_utilization`` of bench/counters.py). This tool renders each scene with the shipped
shaders (A) and with one change (B): the Sobol' scramble keyed by the pixel's 4x2 block instead
of the pixel, so the 8 lanes of a batch draw the same numbers and their rays leave in the same
directions from neighbouring points. B's rays are as coherent as rays can be; its images are
unbiased per pixel but their noise is shared by each block, which is why B is a measurement, not
a mode mcpt ships (Sadeghi et al. 2009, "Coherent Path Tracing", make the same trade). The ratio
B/A is what any reordering of rays into coherent batches (sorting, wavefronts) could gain at most
without correlating pixels.

    python -m mcpt.bench.coherence --scenes sphere100k,bunny,cornell --rounds 3 --spp 8

Both sides run in one process, alternating per round (paths per CPU second: the process's CPU
time, llvmpipe's threads included), then the counters build of each gives its lane utilization.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path

import numpy as np

from mcpt.api import Options, prepare, run
from mcpt.gpu import shader

from .ab import scene_path
from .common import alternate
from .counters import measure

#: The one line B changes in glsl/sobol.glsl, and what it becomes (fragment dispatch only: the
#: block comes from gl_FragCoord).
PER_PIXEL = "g_sobol_pixel = sobol_hash(u_sobol_seed ^ sobol_hash(uint(pixel)));"
PER_BLOCK = ("ivec2 block = ivec2(gl_FragCoord.xy) / ivec2(4, 2); "
             "g_sobol_pixel = sobol_hash(u_sobol_seed ^ sobol_hash(uint(block.y * 4096 + block.x)));")


_SHIPPED = shader.glsl_dir  # the shipped shaders' finder, put back by _use(None)


def block_shaders(dest: Path) -> Path:
    """A copy of glsl/ under ``dest`` with the block-keyed scramble (B)."""
    out = dest / "glsl"
    shutil.copytree(_SHIPPED(), out)
    sobol = out / "sobol.glsl"
    text = sobol.read_text()
    if PER_PIXEL not in text:
        raise SystemExit("glsl/sobol.glsl no longer keys its scramble as this tool expects")
    sobol.write_text(text.replace(PER_PIXEL, PER_BLOCK))
    return out


def _use(folder: Path | None) -> None:
    """Compile from ``folder`` (None: the shipped shaders) from now on; programs are cached by
    feature key, not by source, so the cache is emptied."""
    shader.glsl_dir = _SHIPPED if folder is None else (lambda: folder)
    shader._read.cache_clear()
    shader.clear_cache()


def compare(scene: Path, shaders: dict[str, Path | None], *, spp: int, rounds: int, resolution) -> dict:
    """Side by side: paths per CPU second, image mean and lane utilization of each side (a glsl
    folder, None for the shipped one), and the ratio B/A."""
    prepared = {}
    for side, folder in shaders.items():
        _use(folder)  # programs compile in prepare: the rounds below render what each side built
        prepared[side] = prepare(scene, resolution=resolution, cache=False)
        run(prepared[side], Options(spp=1, seed=0))  # compile and warm up
    try:
        cpu, _, images = alternate(list(shaders), lambda side, k: run(
            prepared[side], Options(spp=spp, seed=k)).result.image, rounds)
    finally:
        for p in prepared.values():
            p.renderer.release()
    means = {side: float(np.mean([r[side][..., :3].mean() for r in images])) for side in shaders}
    paths = rounds * spp * resolution[0] * resolution[1]
    out = {"scene": scene.stem}
    for side, folder in shaders.items():
        _use(folder)
        m = measure(scene, spp=2, resolution=resolution)
        out[side] = {"paths_per_cpu_s": paths / cpu[side], "image_mean": means[side],
                     "lane_utilization": m["lane_utilization"],
                     "batch_iterations_per_ray": m["batch_iterations_per_ray"]}
    out["ratio_B_over_A"] = out["B"]["paths_per_cpu_s"] / out["A"]["paths_per_cpu_s"]
    return out


def _num(x) -> str:
    """A utilization, or '-' where no traversal loop ran (no BVH) or the driver has no ballots."""
    return "-" if x is None else f"{x:.3f}"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", default="sphere100k,bunny,cornell")
    ap.add_argument("--spp", type=int, default=8)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--resolution", type=int, nargs=2, default=(256, 256))
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        sides = {"A": None, "B": block_shaders(Path(tmp))}
        print("scene        A paths/CPU-s  B paths/CPU-s   B/A   utilization A   B   batch iterations/ray A   B")
        for name in args.scenes.split(","):
            r = compare(scene_path(name, Path(tmp)), sides, spp=args.spp, rounds=args.rounds,
                        resolution=tuple(args.resolution))
            a, b = r["A"], r["B"]
            print(f"{name:12s} {a['paths_per_cpu_s'] / 1e6:10.3f} M {b['paths_per_cpu_s'] / 1e6:10.3f} M "
                  f"{r['ratio_B_over_A']:6.2f} {_num(a['lane_utilization']):>12s} {_num(b['lane_utilization']):>6s} "
                  f"{a['batch_iterations_per_ray']:18.3f} {b['batch_iterations_per_ray']:6.3f}", flush=True)
        _use(None)


if __name__ == "__main__":
    main()

"""Non-finite samples, determinism and llvmpipe's loop limit."""

from __future__ import annotations

import numpy as np

from mcpt.gpu.features import LLVMPIPE_LOOP_LIMIT
from mcpt.scene.shipped import shipped
from mcpt.shading.sampler import dims_for

from .core import Env, Outcome, case, compare_images, render
from .furnace import furnace_scene
from .scale import CORNELL_SPP, cornell_reference, cornell_scene

SPHERE_OBJ = shipped("furnace/sphere_inward.obj")
CORNELL_YAML = shipped("cornell-box.yaml")
FURNACE_YAML = shipped("furnace.yaml")
FLT_MAX = float(np.finfo(np.float32).max)



# ---- non-finite samples -----------------------------------------------------------------------

@case("overflow-samples-dropped-and-counted", "non-finite")
def _overflow(env: Env) -> Outcome:
    """A furnace emitting FLT_MAX: every sample is Le + (reflected light) > FLT_MAX = inf. Each is
    detected, left out of the mean and counted; the image stays finite."""
    sc = furnace_scene(env, "flt-max", 0.5, 1, le=FLT_MAX, res=8)
    res, _ = render(env, sc, 4, seed=2)
    n = 8 * 8 * 4
    finite = bool(np.isfinite(res.image).all() and np.isfinite(res.variance).all())
    return Outcome(f"all {n} samples dropped and counted, image finite",
                   f"{res.dropped_samples} dropped, image {'finite' if finite else 'NOT finite'}",
                   res.dropped_samples == n and finite)


@case("non-finite-test-under-fast-math", "non-finite")
def _nonfinite_probe(env: Env) -> Outcome:
    """common.glsl's non_finite() on runtime NaN (0/0), +-Inf (1/0, FLT_MAX * 2) and on finite
    extremes (FLT_MAX, a denormal, 0): llvmpipe's fast-math folds isnan()/isinf(), the bit test
    must not be."""
    from ..probe import run_probe

    uniforms = {"u_zero": 0.0, "u_one": 1.0, "u_max": FLT_MAX, "u_tiny": 1e-40}
    bits = int(run_probe(env.gl, "probe_nonfinite.frag", np.zeros((1, 4), np.uint32), 1,
                         uniforms=uniforms)[0, 0])
    want = 0b00001111
    flags = "".join("1" if bits >> i & 1 else "0" for i in range(8))
    return Outcome("NaN, +Inf, -Inf, 2 FLT_MAX flagged; FLT_MAX, denormal, 0, -FLT_MAX not: 11110000",
                   flags, bits == want)


# ---- determinism -------------------------------------------------------------------------------

@case("same-seed-bit-identical-exr", "determinism")
def _same_seed(env: Env) -> Outcome:
    """Two renders to EXR with the same seed: bit-identical pixels; another seed: different."""
    from mcpt.api import render_scene
    from mcpt.output.image import read_exr

    sc = cornell_scene(env, "det", res=16)
    imgs = []
    for i, seed in enumerate((3, 3, 4)):
        out = env.file(f"det-{i}.exr")
        render_scene(sc, outputs=[out], spp=8, seed=seed, gl_backend=env.gl_backend)
        imgs.append(read_exr(out)[0])
    same = bool(np.array_equal(imgs[0].view(np.uint32), imgs[1].view(np.uint32)))
    other = not np.array_equal(imgs[0], imgs[2])
    return Outcome("seed 3 twice: identical bits; seed 4: different",
                   f"{'identical' if same else 'DIFFERENT'}; {'different' if other else 'IDENTICAL'}",
                   same and other)


@case("tiles-statistically-identical", "determinism")
def _tiles(env: Env) -> Outcome:
    """The same image split into 1 tile and into many (other random streams per tile): the
    two renders agree statistically."""
    sc = cornell_scene(env, "tiles")
    ref = cornell_reference(env)
    dims = dims_for(sc.render.bounces)
    # Tiles exist for the independent sampler's per-pass buffer only (sobol uploads nothing).
    res, _ = render(env, sc, CORNELL_SPP, seed=6, max_random_per_tile=32 * 5 * dims,
                    sampler="independent")
    zt = compare_images(res, ref, res.spp, ref.spp)
    return Outcome(f"{res.setup['tiles']} tiles vs 1: z-test passes",
                   f"{res.setup['tiles']} tiles, {100 * zt.accepted:.2f} % px ok, image-mean z "
                   f"{np.abs(zt.global_z).max():.2f}", zt.passed and res.setup["tiles"] > 1)


@case("accumulation-chunks-agree", "determinism")
def _chunks(env: Env) -> Outcome:
    """The same samples read back every pass (float64 sums) or every 64 (float32 on the GPU):
    equal to float32 rounding."""
    sc = cornell_scene(env, "chunks", res=16)
    a, _ = render(env, sc, 64, seed=8, chunk=1)
    b, _ = render(env, sc, 64, seed=8, chunk=64)
    rel = float(np.max(np.abs(a.image - b.image.astype(np.float64)) / np.maximum(np.abs(a.image), 1e-3)))
    return Outcome("max relative difference < 1e-5", f"{rel:.2e}", rel < 1e-5)


# ---- llvmpipe ----------------------------------------------------------------------------------

@case("llvmpipe-loop-limit", "llvmpipe")
def _loop_limit(env: Env) -> Outcome:
    """How many loop iterations one fragment may run: llvmpipe stops every loop once a pixel has
    taken 65535 back-edges in total (and says nothing). Documents the limit the deep cases hit."""
    from ..probe import run_probe

    n = int(run_probe(env.gl, "probe_loop.frag", np.zeros((1, 4), np.uint32), 1,
                      uniforms={"u_n": 100_000})[0, 0])
    want = LLVMPIPE_LOOP_LIMIT if env.llvmpipe else 100_000
    return Outcome(f"{want} of 100000 iterations ({'llvmpipe' if env.llvmpipe else 'no limit'})",
                   f"{n}", n == want)

"""Furnaces: analytic answers for stiff albedos, deep paths, shipped scenes."""

from __future__ import annotations

import math

import numpy as np

from mcpt.bench.stats import VAR_FLOOR_ABS, VAR_FLOOR_REL, z_test
from mcpt.scene.shipped import shipped

from .core import Env, Outcome, case, fmt, make_scene, render, write_obj

SPHERE_OBJ = shipped("furnace/sphere_inward.obj")
CORNELL_YAML = shipped("cornell-box.yaml")
FURNACE_YAML = shipped("furnace.yaml")
FLT_MAX = float(np.finfo(np.float32).max)



# ---- furnaces ----------------------------------------------------------------------------------

def furnace_expected(albedo: float, bounces: int, le: float = 1.0) -> float:
    """Analytic pixel value of an emissive, diffuse, closed enclosure seen from inside."""
    if albedo == 1.0:
        return le * (bounces + 1)
    return le * (1.0 - albedo ** (bounces + 1)) / (1.0 - albedo)


def sphere_mesh() -> tuple[np.ndarray, np.ndarray]:
    """The shipped geodesic sphere (radius 1, 1280 triangles, wound inward)."""
    from mcpt.shapes.mesh import load_mesh

    m = load_mesh(SPHERE_OBJ)
    return np.array(m.vertices), np.array(m.faces)


def cube_mesh(n: int = 1, jitter: float = 0.0, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Closed cube [-1, 1]^3 wound inward, each face an n x n grid of quads (2 triangles each).

    Shared edges between faces use the same float values, so the mesh is closed; ``jitter`` moves
    the interior grid vertices within their face (triangle areas then differ, up to ~(1+2j)^2:1).
    """
    rng = np.random.default_rng(seed)
    g = np.linspace(-1.0, 1.0, n + 1)
    verts, faces = [], []
    for axis in range(3):
        for side in (-1.0, 1.0):
            u, v = np.meshgrid(g, g, indexing="ij")
            if jitter and n > 1:
                h = 2.0 / n
                inner = (slice(1, n), slice(1, n))
                u[inner] += jitter * h * rng.uniform(-1, 1, (n - 1, n - 1))
                v[inner] += jitter * h * rng.uniform(-1, 1, (n - 1, n - 1))
            p = np.zeros((n + 1, n + 1, 3))
            p[..., axis] = side
            p[..., (axis + 1) % 3] = u
            p[..., (axis + 2) % 3] = v
            base = sum(len(x) for x in verts)
            verts.append(p.reshape(-1, 3))
            idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1) + base
            a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
            faces.append(np.stack([a, b, c], -1).reshape(-1, 3))
            faces.append(np.stack([a, c, d], -1).reshape(-1, 3))
    v = np.concatenate(verts)
    f = np.concatenate(faces)
    # Wind every triangle so its front (counter-clockwise) side faces the centre.
    nrm = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    outward = np.einsum("ij,ij->i", nrm, v[f].mean(axis=1)) > 0
    f[outward] = f[outward][:, [0, 2, 1]]
    return v, f


def furnace_scene(env: Env, name: str, albedo: float, bounces: int, *, le: float = 1.0,
                  mesh=None, scale: float = 1.0, offset=(0.0, 0.0, 0.0), res: int = 16):
    """Camera at the centre of a closed emissive diffuse enclosure (default: the sphere)."""
    if mesh is None:
        path = SPHERE_OBJ
    else:
        path = write_obj(env.file(f"{name}.obj"), *mesh)
    off = [float(x) for x in offset]
    return make_scene(
        env, name, bounces=bounces,
        camera={"position": off, "look_at": [off[0], off[1], off[2] - 1.0], "up": [0, 1, 0],
                "vfov_deg": 60.0, "resolution": [res, res]},
        materials={"f": {"albedo": [albedo] * 3, "emission": [le] * 3}},
        meshes=[{"file": path, "material": "f",
                 "transform": {"scale": scale, "translate": off}}])


def judge_furnace(result, expected: float) -> Outcome:
    """Every pixel and the image mean against the analytic value.

    The pixels of a furnace are identically distributed, so each pixel's variance is the POOLED
    variance of all of them (a 16-sample estimate of one pixel's own variance is too noisy for a
    z-test under roulette's skew)."""
    img = np.asarray(result.image, np.float64)[..., 0]   # grey: the channels are one test
    var = np.asarray(result.variance, np.float64)[..., 0]
    pooled = np.full_like(img, var.mean())
    floor = (VAR_FLOOR_ABS + VAR_FLOOR_REL * expected**2) / result.spp
    # 16x16 pixels: 0.25 % is less than one pixel, so one rejected pixel is tolerated.
    zt = z_test(img, np.full_like(img, expected), pooled, 0.0, var_floor=floor, allow=1)
    mean = img.mean()
    se = math.sqrt(pooled.mean() / img.size)
    ok = zt.passed and result.dropped_samples == 0
    return Outcome(f"L = {fmt(expected)} everywhere, no sample dropped",
                   f"mean {mean:.5g} ± {se:.2g} (z {zt.global_z[0]:+.2f}), {100 * zt.accepted:.2f} % "
                   f"px ok, dropped {result.dropped_samples}", ok)


def _furnace_case(name, albedo, bounces, *, spp=32, res=16, le=1.0, mesh=None, scale=1.0,
                  offset=(0, 0, 0), known=None, group="furnace", **flags):
    @case(name, group, known)
    def run(env: Env) -> Outcome:
        sc = furnace_scene(env, name, albedo, bounces, le=le, mesh=mesh() if mesh else None,
                           scale=scale, offset=offset, res=res)
        res_, _ = render(env, sc, spp, seed=11, **flags)
        return judge_furnace(res_, furnace_expected(albedo, bounces, le))
    return run


_furnace_case("furnace-a0.5-b8", 0.5, 8, spp=64)
_furnace_case("furnace-a0.8-b8-cube12-nobvh", 0.8, 8, spp=64, mesh=lambda: cube_mesh(1))
_furnace_case("furnace-a0.8-b8-nee-only", 0.8, 8, spp=64, sampling="nee")
_furnace_case("furnace-a0.99-b64", 0.99, 64, spp=32)
_furnace_case("furnace-a0.999-b64", 0.999, 64, spp=32)
_furnace_case("furnace-a0.999-b64-no-rr", 0.999, 64, spp=8, russian_roulette=False)
_furnace_case("furnace-a1-b64-no-rr", 1.0, 64, spp=8, russian_roulette=False)
_furnace_case("furnace-a1-b300-no-rr", 1.0, 300, spp=2, res=8, russian_roulette=False)


@case("loop-limit-reached-is-counted", "non-finite")
def _loop_limit_counted(env: Env) -> Outcome:
    """A 20000-bounce path cannot finish inside llvmpipe's 65535 loop iterations: every sample
    must be dropped and counted (glsl/common.glsl MCPT_LOOP_LIMIT), not come out silently dark.
    Elsewhere (no loop limit) the path completes: L = 20001 (albedo 1, no roulette)."""
    sc = furnace_scene(env, "deep", 1.0, 20000, res=4)
    # continuation=False: one draw per pass, as before paths were continued across draws
    # (the "deep-paths-continue" case checks the default).
    res, p = render(env, sc, 2, seed=3, russian_roulette=False, continuation=False)
    n = res.image.shape[0] * res.image.shape[1] * res.spp
    if env.llvmpipe:
        ok = res.dropped_samples == n and np.isfinite(res.image).all()
        return Outcome(f"all {n} samples dropped and counted", f"{res.dropped_samples} dropped", ok)
    mean = float(res.image.mean())
    return Outcome("L = 20001, none dropped", f"mean {mean:.1f}, {res.dropped_samples} dropped",
                   res.dropped_samples == 0 and abs(mean / 20001 - 1) < 1e-3)
_furnace_case("furnace-6912-emitters", 0.5, 4, spp=64, group="lights",
              mesh=lambda: cube_mesh(24, jitter=0.35, seed=3))


@case("furnace-shipped-scene", "furnace")
def _shipped_furnace(env: Env) -> Outcome:
    """scenes/furnace.yaml as shipped (albedo 0.8, 8 bounces) against scene.json's value."""
    from mcpt.scene import load_scene

    sc = load_scene(FURNACE_YAML).with_overrides(resolution=(16, 16))
    res, _ = render(env, sc, 64, seed=12)
    return judge_furnace(res, furnace_expected(0.8, 8))


@case("furnace-a0-exact", "furnace")
def _black_furnace(env: Env) -> Outcome:
    """Albedo 0: every sample sees the emitter once, so every pixel is exactly Le (no noise)."""
    sc = furnace_scene(env, "furnace-a0", 0.0, 8, le=0.75)
    res, _ = render(env, sc, 4, seed=13)
    exact = float(np.mean(res.image == np.float32(0.75)))
    return Outcome("every pixel exactly 0.75", f"{100 * exact:.2f} % exact, min {res.image.min():.7g},"
                   f" max {res.image.max():.7g}", exact == 1.0 and res.dropped_samples == 0)

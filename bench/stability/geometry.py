"""Geometry: identical centroids, duplicates."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from mcpt.bench.stats import z_test
from mcpt.scene.shipped import shipped

from .core import Env, Outcome, case, make_scene, render, write_obj
from .scale import CORNELL_SPP, _cornell_reference, cornell_reference, cornell_scene, judge_offset, judge_same_image

SPHERE_OBJ = shipped("furnace/sphere_inward.obj")
CORNELL_YAML = shipped("cornell-box.yaml")
FURNACE_YAML = shipped("furnace.yaml")
FLT_MAX = float(np.finfo(np.float32).max)



# ---- geometry: identical centroids, duplicates ---------------------------------------------------

def star_cluster(n: int, radius: float = 1.0, z: float = -3.0):
    """n equilateral triangles rotated about one common centroid in the plane z: all centroids
    are equal, every box overlaps every other, and together they cover the disk of ``radius``."""
    ang = np.arange(n) * (2 * np.pi / 3) / n
    k = np.arange(3) * 2 * np.pi / 3
    a = ang[:, None] + k[None, :]
    v = np.stack([radius * np.cos(a), radius * np.sin(a), np.full(a.shape, z)], -1)
    return v.reshape(-1, 3), np.arange(3 * n).reshape(n, 3)


@case("identical-centroids-1e6-bvh", "geometry")
def _cluster_bvh(env: Env) -> Outcome:
    """10^6 triangles with one common centroid: the median builder still halves by position, so
    the depth stays at ceil(log2(F / 4)) + 1 and the traversal stack (depth + 2) never overflows."""
    from mcpt.shapes.bvh import MAX_STACK
    from mcpt.shapes.bvh_build import build_bvh

    v, f = star_cluster(1_000_000)
    t0 = time.perf_counter()
    bvh = build_bvh(v[f])
    secs = time.perf_counter() - t0
    bound = math.ceil(math.log2(1_000_000 / bvh.max_leaf)) + 1
    ok = bvh.depth <= bound and bvh.depth + 2 <= MAX_STACK
    return Outcome(f"depth <= {bound}, stack {MAX_STACK} enough",
                   f"depth {bvh.depth}, {bvh.num_nodes} nodes, built in {secs:.1f} s", ok)


def _cluster_case(n: int, known=None):
    @case(f"identical-centroids-{n:.0e}-render".replace("+0", ""), "geometry", known)
    def run(env: Env) -> Outcome:
        """The cluster as a black disk in front of an emissive wall, bounces 0: each pixel is the
        fraction of its area outside the disk (binomial noise), computed on a 16x16 sub-grid."""
        from mcpt.shading.camera import basis

        v, f = star_cluster(n, radius=1.0, z=-3.0)
        wall = np.array([[-9.0, -9.0, -5.0], [9.0, -9.0, -5.0], [9.0, 9.0, -5.0], [-9.0, 9.0, -5.0]])
        star = write_obj(env.file(f"star-{n}.obj"), v, f)
        back = write_obj(env.file("wall.obj"), wall, np.array([[0, 1, 2], [0, 2, 3]]))
        px = 16
        cam = {"position": [0.0, 0.0, 0.0], "look_at": [0.0, 0.0, -1.0], "vfov_deg": 60.0,
               "resolution": [px, px]}
        sc = make_scene(env, f"star-{n}", camera=cam, bounces=0,
                        materials={"black": {"albedo": [0, 0, 0], "emission": [0, 0, 0]},
                                   "wall": {"albedo": [0, 0, 0], "emission": [1, 1, 1]}},
                        meshes=[{"file": star, "material": "black"}, {"file": back, "material": "wall"}])
        res, p = render(env, sc, 16, seed=4)
        fw, r, u = basis(cam["position"], cam["look_at"], [0, 1, 0], 60.0, px, px)
        g = (np.arange(16) + 0.5) / 16
        sx, sy = np.meshgrid(g, g)
        i, j = np.meshgrid(np.arange(px), np.arange(px))
        x = 2.0 * (i[..., None, None] + sx) / px - 1.0
        y = 1.0 - 2.0 * (j[..., None, None] + sy) / px
        d = fw + x[..., None] * r + y[..., None] * u
        hit = d * (3.0 / -d[..., 2])[..., None]
        inside = np.hypot(hit[..., 0], hit[..., 1]) < 1.0
        expected = 1.0 - inside.reshape(px, px, -1).mean(-1)
        img = res.image.astype(np.float64)[..., 0]
        var = expected * (1 - expected) / res.spp
        zt = z_test(img, expected, var, 0.0, var_floor=1e-4 / res.spp, allow=1)
        return Outcome("pixels = area outside the disk (binomial z-test)",
                       f"mean {img.mean():.4f} vs {expected.mean():.4f}, {100 * zt.accepted:.2f} % px ok"
                       f" (max |z| {np.abs(zt.z).max():.1f})", zt.passed and res.dropped_samples == 0)
    return run


_cluster_case(1000)
_cluster_case(10000)
_cluster_case(100_000)


@case("cornell-offset-1e5-in-obj-files", "offset")
def _offset_in_files(env: Env) -> Outcome:
    """The Cornell box with 1e5 added to every coordinate IN the OBJ files (camera moved too).
    Assimp parses OBJ coordinates as float32 (1/128 steps at 1e5); mcpt/shapes/mesh.py reads them back
    in float64 so the camera-relative rebasing can keep them."""
    import yaml

    from mcpt.shapes.mesh import load_mesh

    off = np.array([1e5, 0.5e5, -0.25e5])
    doc = yaml.safe_load(CORNELL_YAML.read_text())
    files = {}
    for m in doc["meshes"]:
        mesh = load_mesh(CORNELL_YAML.parent / m["file"])
        files[m["file"]] = write_obj(env.file("far-" + Path(m["file"]).name),
                                     mesh.vertices + off, mesh.faces)
    return judge_offset(env, cornell_scene(env, "cornell-offset-in-files", mesh_files=files,
                                           offset=off, transform_meshes=False))


def _duplicated_files(env: Env, names, copies: int = 2) -> dict:
    """Cornell mesh files with every face repeated ``copies`` times (same vertices)."""
    from mcpt.shapes.mesh import load_mesh

    out = {}
    for n in names:
        m = load_mesh(CORNELL_YAML.parent / n)
        out[n] = write_obj(env.file("dup-" + Path(n).name), m.vertices, np.tile(m.faces, (copies, 1)))
    return out


@case("duplicated-triangles", "geometry")
def _duplicates(env: Env) -> Outcome:
    """The Cornell box with every face of the light and of the white walls written twice: a
    duplicate is the same surface, so the image must be the same (an emitter counted twice by
    light sampling but once by BSDF hits would brighten the direct light)."""
    files = _duplicated_files(env, ["cornell/light.obj", "cornell/white_walls.obj"])
    res, p = render(env, cornell_scene(env, "duplicates", mesh_files=files), CORNELL_SPP, seed=5)
    ref, p_ref = _cornell_reference(env)
    out = judge_same_image(res, ref, "without duplicates")
    out.measured = (f"{p.world.n_triangles} triangles (vs {p_ref.world.n_triangles}), "
                    f"{p.world.lights.count} lights, " + out.measured)
    return out


@case("duplicated-emitter-across-files", "geometry")
def _duplicate_files(env: Env) -> Outcome:
    """The Cornell light listed twice in the scene file (two mesh entries, one OBJ)."""
    light = {"file": (CORNELL_YAML.parent / "cornell/light.obj").resolve(), "material": "light"}
    res, p = render(env, cornell_scene(env, "dup-entry", extra_meshes=[light]), CORNELL_SPP, seed=5)
    ref = cornell_reference(env)
    out = judge_same_image(res, ref, "with the light listed once")
    out.measured = f"{p.world.lights.count} lights, " + out.measured
    return out

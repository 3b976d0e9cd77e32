"""Lights: tiny and bright, zero area, thousands."""

from __future__ import annotations

import numpy as np

from mcpt.bench.stats import VAR_FLOOR_ABS, VAR_FLOOR_REL, z_test
from mcpt.scene.shipped import shipped

from .core import Env, Outcome, case, compare_images, fmt, make_scene, render, write_obj
from .scale import CORNELL_SPP, cornell_reference, cornell_scene

SPHERE_OBJ = shipped("furnace/sphere_inward.obj")
CORNELL_YAML = shipped("cornell-box.yaml")
FURNACE_YAML = shipped("furnace.yaml")
FLT_MAX = float(np.finfo(np.float32).max)



# ---- lights: tiny and bright, zero area, thousands -----------------------------------------------

def _square(center, side: float, normal_sign: float):
    """Two triangles of a horizontal square (normal +-y), as (vertices, faces)."""
    c = np.asarray(center, np.float64)
    h = side / 2
    v = c + np.array([[-h, 0, -h], [h, 0, -h], [h, 0, h], [-h, 0, h]])
    f = np.array([[0, 2, 1], [0, 3, 2]]) if normal_sign > 0 else np.array([[0, 1, 2], [0, 2, 3]])
    return v, f


def polygon_irradiance(x: np.ndarray, n: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Irradiance at points ``x`` (normal ``n``) from a polygon of unit radiance, by Lambert's
    formula E = 1/2 sum_i angle_i (n . unit(p_i x p_i+1)) (exact for a fully visible polygon)."""
    e = np.zeros(len(x))
    k = len(poly)
    for i in range(k):
        a = poly[i] - x
        b = poly[(i + 1) % k] - x
        c = np.cross(a, b)
        cn = np.linalg.norm(c, axis=1)
        ang = np.arctan2(cn, np.einsum("ij,ij->i", a, b))   # stable for tiny angles (not acos)
        e += 0.5 * ang * (c @ n) / cn
    return np.abs(e)


def _tiny_light_case(side: float):
    name = f"tiny-light-{side:g}"

    @case(name, "lights")
    def run(env: Env) -> Outcome:
        """A square light of side ``side``, radiance 1/side^2 (same power), 1 unit above a diffuse
        floor; the camera looks straight down from below the light. Direct light only."""
        from mcpt.shading.camera import basis

        rho, height, cam_y = 0.5, 1.0, 0.5
        lv, lf = _square((0.0, height, 0.0), side, -1.0)
        fv, ff = _square((0.0, 0.0, 0.0), 4.0, +1.0)
        light = write_obj(env.file(f"{name}-light.obj"), lv, lf)
        floor = write_obj(env.file(f"{name}-floor.obj"), fv, ff)
        res_px = 16
        cam = {"position": [0.0, cam_y, 0.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, -1.0],
               "vfov_deg": 60.0, "resolution": [res_px, res_px]}
        le = 1.0 / side**2
        sc = make_scene(env, name, camera=cam, bounces=1,
                        materials={"floor": {"albedo": [rho] * 3, "emission": [0, 0, 0]},
                                   "light": {"albedo": [0, 0, 0], "emission": [le] * 3}},
                        meshes=[{"file": floor, "material": "floor"},
                                {"file": light, "material": "light"}])
        res, p = render(env, sc, 64, seed=21)
        # Expected: rho/pi * E over each pixel (8x8 sub-pixel grid), with the light's float32
        # vertices as uploaded (camera-relative, back to world by adding the camera position).
        world = p.world
        lt = world.lights.triangles
        tri = world.tris[lt].astype(np.float64) + np.asarray(cam["position"])
        f, r, u = basis(cam["position"], cam["look_at"], cam["up"], cam["vfov_deg"], res_px, res_px)
        g = (np.arange(8) + 0.5) / 8
        sx, sy = np.meshgrid(g, g)
        i, j = np.meshgrid(np.arange(res_px), np.arange(res_px))
        px = 2.0 * (i[..., None, None] + sx) / res_px - 1.0
        py = 1.0 - 2.0 * (j[..., None, None] + sy) / res_px
        d = f + px[..., None] * r + py[..., None] * u
        hit = np.asarray(cam["position"]) + d * (-cam_y / d[..., 1])[..., None]
        pts = hit.reshape(-1, 3)
        e = sum(polygon_irradiance(pts, np.array([0.0, 1.0, 0.0]), t) for t in tri) * le
        expected = (rho / np.pi * e).reshape(res_px, res_px, -1).mean(axis=-1)
        img = res.image.astype(np.float64)[..., 0]
        var = res.variance.astype(np.float64)[..., 0]
        floor_v = (VAR_FLOOR_ABS * 1e-4 + VAR_FLOOR_REL * expected**2) / res.spp
        zt = z_test(img, expected, var, 0.0, var_floor=floor_v, allow=1)
        ok = zt.passed and res.dropped_samples == 0
        return Outcome(f"floor radiance rho E / pi (Lambert's polygon formula), mean "
                       f"{fmt(expected.mean())}", f"mean {img.mean():.6g} (z {zt.global_z[0]:+.2f}), "
                       f"{100 * zt.accepted:.2f} % px ok, dropped {res.dropped_samples}", ok)
    return run


for _side in (1e-2, 1e-4, 1e-6):
    _tiny_light_case(_side)


def _small_emitter(center, size: float):
    """One emissive triangle facing down (normal -y)."""
    c = np.asarray(center, np.float64)
    return c + size * np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]), np.array([[0, 1, 2]])


@case("zero-area-emitters", "lights")
def _zero_area(env: Env) -> Outcome:
    """An emitter mesh of one real triangle plus 4 zero-area ones (collinear corners, repeated
    corners): the degenerate ones are dropped and counted, the image equals the one without them."""
    v, f = _small_emitter((0.2, 0.5, 0.2), 0.1)
    bad_v = np.array([[0.0, 0.5, 0.0], [0.1, 0.5, 0.0], [0.2, 0.5, 0.0], [0.3, 0.3, 0.3]])
    bad_f = np.array([[0, 1, 2], [0, 0, 3], [3, 3, 3], [2, 1, 0]]) + 3
    good = write_obj(env.file("emitter-good.obj"), v, f)
    mixed = write_obj(env.file("emitter-mixed.obj"), np.concatenate([v, bad_v]), np.concatenate([f, bad_f]))
    mat = {"hot": {"albedo": [0, 0, 0], "emission": [50, 50, 50]}}
    ref, p_ref = render(env, cornell_scene(env, "za-ref", res=16, extra_materials=mat,
                                           extra_meshes=[{"file": good, "material": "hot"}]), 16, seed=9)
    res, p = render(env, cornell_scene(env, "za-mixed", res=16, extra_materials=mat,
                                       extra_meshes=[{"file": mixed, "material": "hot"}]), 16, seed=9)
    dropped = p.world.stats["dropped_degenerate"]
    same = bool(np.array_equal(res.image, ref.image))
    ok = same and dropped == 4 and p.world.lights.count == p_ref.world.lights.count
    return Outcome("4 degenerate triangles dropped, image bit-identical",
                   f"{dropped} dropped, {p.world.lights.count} lights (vs {p_ref.world.lights.count}), "
                   f"image {'bit-identical' if same else 'differs'}", ok)


@case("emitter-zero-area-in-float32", "lights")
def _collapsed_emitter(env: Env) -> Outcome:
    """An emitter of size 1e-9 at distance ~4 from the camera: valid in float64, but its float32
    corners coincide after the upload. It must become no light and leave the image unchanged."""
    # The tiny size comes from the (float64) YAML transform.
    v, f = _small_emitter((0.0, 0.0, 0.0), 1.0)
    path = write_obj(env.file("emitter-collapsed.obj"), v, f)
    mat = {"hot": {"albedo": [0, 0, 0], "emission": [1e6, 1e6, 1e6]}}
    tiny = {"file": path, "material": "hot", "transform": {"scale": 1e-9, "translate": [0.3, 0.2, 0.1]}}
    res, p = render(env, cornell_scene(env, "collapsed", extra_materials=mat, extra_meshes=[tiny]),
                    CORNELL_SPP, seed=5)
    ref = cornell_reference(env)
    zt = compare_images(res, ref, res.spp, ref.spp)
    same = float(np.mean(res.image == ref.image))
    lights_ref = 2  # the Cornell light: two triangles
    ok = zt.passed and p.world.lights.count == lights_ref and res.dropped_samples == 0
    return Outcome(f"{lights_ref} lights (the collapsed one is none), image unchanged",
                   f"{p.world.lights.count} lights, {100 * same:.1f} % bit-identical, "
                   f"{100 * zt.accepted:.2f} % px ok, dropped {res.dropped_samples}", ok)

"""Scale and offset sweeps of the Cornell box: the image must not change."""

from __future__ import annotations

import numpy as np

from mcpt.scene.shipped import shipped

from .core import Env, Outcome, case, compare_images, make_scene, render
from .furnace import _furnace_case

SPHERE_OBJ = shipped("furnace/sphere_inward.obj")
CORNELL_YAML = shipped("cornell-box.yaml")
FURNACE_YAML = shipped("furnace.yaml")
FLT_MAX = float(np.finfo(np.float32).max)



# ---- scale and offset sweeps (Cornell box) -------------------------------------------------------

def cornell_scene(env: Env, name: str, *, scale: float = 1.0, offset=(0.0, 0.0, 0.0), res: int = 32,
                  extra_meshes=(), extra_materials=None, mesh_files=None, bounces: int = 8,
                  transform_meshes: bool = True):
    """The shipped Cornell box, uniformly scaled about the origin then moved by ``offset`` (the
    camera with it), optionally with extra meshes or replaced mesh files (``transform_meshes``
    False: the replaced files are already where they belong, only the camera moves)."""
    import yaml

    doc = yaml.safe_load(CORNELL_YAML.read_text())
    off = np.asarray(offset, np.float64)
    cam = dict(doc["camera"])
    for k in ("position", "look_at"):
        cam[k] = (np.asarray(cam[k], np.float64) * scale + off).tolist()
    cam["resolution"] = [res, res]
    meshes = []
    for m in doc["meshes"]:
        f = (CORNELL_YAML.parent / m["file"]).resolve()
        if mesh_files and m["file"] in mesh_files:
            f = mesh_files[m["file"]]
        mesh = {"file": f, "material": m["material"]}
        if transform_meshes:
            mesh["transform"] = {"scale": scale, "translate": off.tolist()}
        meshes.append(mesh)
    meshes += list(extra_meshes)
    return make_scene(env, name, camera=cam, meshes=meshes, bounces=bounces,
                      materials={**doc["materials"], **(extra_materials or {})})


CORNELL_SPP = 64


def cornell_reference(env: Env):
    """The Cornell box at scale 1, 32x32, 64 spp, seed 5 (rendered once per environment)."""
    return _cornell_reference(env)[0]


def _cornell_reference(env: Env):
    if "cornell" not in env.cache:
        env.cache["cornell"] = render(env, cornell_scene(env, "cornell-ref"), CORNELL_SPP, seed=5)
    return env.cache["cornell"]


def load_order_tris(world) -> np.ndarray:
    """The uploaded (camera-relative float32) triangles back in load order."""
    return world.tris[np.argsort(world.bvh.order)]


def judge_offset(env: Env, scene) -> Outcome:
    """A scene moved far away, camera with it: the uploaded camera-relative triangles must equal
    the origin scene's to one float32 ulp, and the image must be the same."""
    res, p = render(env, scene, CORNELL_SPP, seed=5)
    ref, p_ref = _cornell_reference(env)
    a, b = load_order_tris(p.world), load_order_tris(p_ref.world)
    ulp = np.spacing(np.abs(b).astype(np.float32)).astype(np.float64)
    dev = np.abs(a.astype(np.float64) - b) / ulp
    out = judge_same_image(res, ref, "at the origin")
    worst = float(np.abs(a.astype(np.float64) - b).max())
    out.expected = "vertices within 1 float32 ulp of the origin scene's, " + out.expected
    out.measured = f"vertices off by <= {dev.max():.0f} ulp ({worst:.2g}), " + out.measured
    out.passed = out.passed and dev.max() <= 1.0
    return out


def judge_same_image(res, ref, what: str) -> Outcome:
    """A render with the same seed as ``ref`` of a transformed scene: statistically the same image
    (z-test as if independent, which only makes it more lenient) and mostly bit-identical."""
    zt = compare_images(res, ref, res.spp, ref.spp)
    same = float(np.mean(res.image == ref.image))
    ratio = float(res.image.mean() / ref.image.mean())
    ok = zt.passed and res.dropped_samples == 0
    return Outcome(f"same image as {what}", f"{100 * zt.accepted:.2f} % px ok, mean ratio {ratio:.5f}"
                   f" (z {np.abs(zt.global_z).max():.2f}), {100 * same:.1f} % bit-identical", ok)


def _scale_case(scale: float):
    @case(f"cornell-scale-{scale:g}", "scale")
    def run(env: Env) -> Outcome:
        sc = cornell_scene(env, f"cornell-scale-{scale:g}", scale=scale)
        res, _ = render(env, sc, CORNELL_SPP, seed=5)
        return judge_same_image(res, cornell_reference(env), "at scale 1")


for _s in (1e-4, 1e-2, 1e2, 1e4):
    _scale_case(_s)


def _offset_case(distance: float):
    @case(f"cornell-offset-{distance:g}", "offset")
    def run(env: Env) -> Outcome:
        off = (distance, 0.5 * distance, -0.25 * distance)
        return judge_offset(env, cornell_scene(env, f"cornell-offset-{distance:g}", offset=off))


for _d in (1e3, 1e5, 1e7):
    _offset_case(_d)

_furnace_case("furnace-scale-1e-4", 0.8, 8, spp=32, scale=1e-4, group="scale")
_furnace_case("furnace-scale-1e4", 0.8, 8, spp=32, scale=1e4, group="scale")
_furnace_case("furnace-offset-1e5", 0.8, 8, spp=32, offset=(1e5, -1e5, 3e4), group="offset")

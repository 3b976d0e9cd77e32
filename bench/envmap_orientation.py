"""Environment-map orientation against Mitsuba 3 itself (issue #20): a 32 x 16 map, dim random
texels plus three bright ones of different colours (red towards +Z, green towards -Z, blue
towards +X), rendered by Mitsuba's ``envmap`` through perspective cameras looking along +Z, -Z
and +X (and +X again with the map turned 90 degrees about +Y). For every camera the image mcpt's
reference lookup predicts (EnvMap.eval, the same function as glsl/envmap.glsl env_radiance, of
Mitsuba's own camera rays, 4 x 4 per pixel) must put the bright spot on the same pixel and match
the render to Monte Carlo noise.

    MCPT_PEER_PYTHON=/path/to/.venv-peer/bin/python .venv/bin/python -m mcpt.bench.envmap_orientation

The Mitsuba half runs as ``<peer python> envmap_orientation.py --peer-side MAP OUT`` (it imports
mitsuba and numpy only; mcpt is not installed in the peer's venv).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

W, H = 32, 16
SPOTS = {(15, 7): (60.0, 0.0, 0.0), (0, 5): (0.0, 60.0, 0.0), (7, 9): (0.0, 0.0, 60.0)}  # (x, y): RGB
CAMERAS = {"+Z": ((0, 0, 1), 0.0), "-Z": ((0, 0, -1), 0.0), "+X": ((1, 0, 0), 0.0),  # (look at, map turned)
           "+X, map turned 90 deg": ((1, 0, 0), 90.0)}
RES, FOV, SPP, SUB = 48, 90.0, 256, 4


def rot_y(deg: float) -> np.ndarray:
    """Right-handed rotation about +Y (Mitsuba's Transform4f.rotate([0, 1, 0], deg))."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def test_map() -> np.ndarray:
    img = 0.05 + 0.1 * np.random.default_rng(3).random((H, W, 3))
    for (x, y), rgb in SPOTS.items():
        img[y, x] = rgb
    return img.astype(np.float32)


def peer_side(map_path: str, out: str) -> None:
    # Run as a script, this file's folder leads sys.path, and its bench/mitsuba.py would shadow
    # the real mitsuba package.
    here = Path(__file__).resolve().parent
    sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != here]
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    result = {}
    for k, (target, deg) in enumerate(CAMERAS.values()):
        scene = mi.load_dict({
            "type": "scene",
            "integrator": {"type": "path", "max_depth": 2},
            "sensor": {"type": "perspective", "fov": FOV,
                       "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 0], target=list(target), up=[0, 1, 0]),
                       "film": {"type": "hdrfilm", "width": RES, "height": RES, "rfilter": {"type": "box"}},
                       "sampler": {"type": "independent", "sample_count": SPP}},
            "env": {"type": "envmap", "filename": map_path,
                    "to_world": mi.ScalarTransform4f().rotate([0, 1, 0], deg)},
        })
        result[f"image{k}"] = np.array(mi.render(scene, seed=k))[:, :, :3]
        sensor = scene.sensors()[0]
        dirs = np.zeros((RES, RES, SUB * SUB, 3))
        for y in range(RES):
            for x in range(RES):
                for s in range(SUB * SUB):
                    pos = mi.ScalarPoint2f((x + (s % SUB + 0.5) / SUB) / RES, (y + (s // SUB + 0.5) / SUB) / RES)
                    ray, _ = sensor.sample_ray(0.0, 0.5, pos, mi.ScalarPoint2f(0.5, 0.5))
                    dirs[y, x, s] = [ray.d[0], ray.d[1], ray.d[2]]
        result[f"dirs{k}"] = dirs
    np.savez(out, **result)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--peer-side", nargs=2, metavar=("MAP", "OUT"))
    args = ap.parse_args(argv)
    if args.peer_side:
        peer_side(*args.peer_side)
        return 0

    from mcpt.output.image import write_exr
    from mcpt.shading.envmap import build_envmap, read_envmap

    from .mitsuba import python

    with tempfile.TemporaryDirectory() as tmp:
        map_path, out = Path(tmp) / "spots.exr", Path(tmp) / "mitsuba.npz"
        write_exr(map_path, test_map())
        subprocess.run([str(python()), __file__, "--peer-side", str(map_path), str(out)], check=True)
        res = np.load(out)
        img = read_envmap(map_path)
    worst = 0.0
    for k, (name, (_, deg)) in enumerate(CAMERAS.items()):
        env = build_envmap(img, to_world=rot_y(deg))
        theirs = res[f"image{k}"]
        ours = env.eval(res[f"dirs{k}"].reshape(-1, 3)).reshape(RES, RES, SUB * SUB, 3).mean(axis=2)
        spot_t = np.unravel_index(np.argmax(theirs.sum(axis=2)), theirs.shape[:2])
        spot_o = np.unravel_index(np.argmax(ours.sum(axis=2)), ours.shape[:2])
        colour = "RGB"[int(np.argmax(theirs[spot_t]))]
        rel = float(np.abs(ours - theirs).sum() / np.abs(theirs).sum())
        worst = max(worst, rel)
        print(f"camera {name:22s}: Mitsuba's brightest pixel (row, col) {tuple(map(int, spot_t))} ({colour}), "
              f"mcpt's {tuple(map(int, spot_o))}; relative L1 difference of the images {rel:.4f}")
        if spot_t != spot_o:
            print("  MISMATCH of the bright spot")
            worst = np.inf
    print(f"worst relative L1 difference {worst:.4f} ({SPP} spp box filter against a 4 x 4 quadrature)")
    return 0 if worst < 0.05 else 1


if __name__ == "__main__":
    raise SystemExit(main())

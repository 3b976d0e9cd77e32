"""Set-up speed of a 10^6-triangle scene (issue #23): mcpt cold, mcpt from the set-up cache, and
Mitsuba 3 loading the same OBJ, side by side in one run.

    python -m mcpt.bench.setup_speed [--scene DIR] [--rounds 5] [--json OUT]

The scene is ``cornell-sphere-1m`` of ``../shared/tools/make_ref_scenes.py`` (the Cornell box with a
1 003 544-triangle geodesic sphere); without ``--scene`` it is generated into a temporary folder.
Every measurement is a fresh child process (imports and process start excluded on both sides,
the OBJ in the OS page cache on both sides), the kinds alternate within each round, and the table
gives medians:

    mcpt cold    an empty set-up cache (the entry is written: what a first render pays)
    mcpt warm    the entry the cold run just wrote (a second render, a resume, a farm worker)
    mitsuba obj  ``mi.load_dict`` of the sphere's OBJ shape (llvm_ad_rgb)
    mitsuba scn  ``mi.load_dict`` of a scene holding that shape (adds Mitsuba's BVH build)

mcpt's columns: ``host`` = scene file read, world built (meshes, duplicates, BVH, lights) or read
back, features derived, buffers packed or read back: prepare() less the GL work; ``gl`` = program
compile and buffer upload; ``ctx`` = GL context creation (llvmpipe, the same for any scene).
``cpu`` = the process's CPU seconds over ``total`` (all its threads): steadier than wall time on a
loaded machine. The ratio column is total over Mitsuba's OBJ load, medians of each.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from . import mitsuba, scenes

SCENE = "cornell-sphere-1m"

_MCPT_CHILD = """
import json, sys, time
from mcpt.gpu.context import shared_context
from mcpt.gpu.features import for_world, loop_limit_for
from mcpt.gpu.pack import pack
from mcpt.gpu.pack_cache import cached_pack
from mcpt.gpu.render import Renderer
from mcpt.scene import load_scene
from mcpt.shapes.world import load_world
from mcpt.shapes.world_cache import cached_world
from mcpt.heap import setup_heap
t0 = time.perf_counter(); gl = shared_context(None); t1 = time.perf_counter(); c1 = time.process_time()
with setup_heap():  # as mcpt.prepare.prepare sets up
    scene = load_scene(sys.argv[1])
    world = cached_world(scene, load_world)
    feats = for_world(world, loop_limit=loop_limit_for(gl.renderer))
    packed = cached_pack(world, feats, pack)
    t2 = time.perf_counter()
    renderer = Renderer(gl, feats, packed)
t3 = time.perf_counter()
print(json.dumps({"ctx": t1 - t0, "host": t2 - t1, "gl": t3 - t2, "total": t3 - t1, "cpu": time.process_time() - c1,
                  "cache": world.stats.get("cache"), "triangles": world.n_triangles}))
"""

_PEER_CHILD = """
import json, sys, time
sys.path.insert(0, sys.argv[2])
from peer_mitsuba import _import_mitsuba
mi, dr, _ = _import_mitsuba("llvm_ad_rgb")
t0, c0 = time.perf_counter(), time.process_time()
if sys.argv[3] == "obj":
    shape = mi.load_dict({"type": "obj", "filename": sys.argv[1]})
    n = shape.face_count()
else:
    scene = mi.load_dict({"type": "scene", "sphere": {"type": "obj", "filename": sys.argv[1]}})
    n = sum(s.face_count() for s in scene.shapes())
print(json.dumps({"total": time.perf_counter() - t0, "cpu": time.process_time() - c0, "triangles": int(n),
                  "version": mi.__version__}))
"""


def scene_dir(given: Path | None, work: Path) -> Path:
    """``given``, else ../shared/scenes-ref/cornell-sphere-1m, else one generated into ``work``."""
    if given is not None:
        return given
    shared = scenes.shared_dir() / "scenes-ref" / SCENE
    if (shared / "sphere.obj").is_file():
        return shared
    tool = scenes.shared_dir() / "tools" / "make_ref_scenes.py"
    subprocess.run([sys.executable, str(tool), "--out", str(work), "--only", SCENE, "--with-1m"],
                   check=True, capture_output=True)
    return work / SCENE


def _child(cmd: list[str], env: dict | None = None) -> dict:
    out = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    if out.returncode != 0:
        raise RuntimeError(f"{cmd[:3]} failed: {out.stderr.strip()[-800:]}")
    return json.loads(mitsuba._ANSI.sub("", out.stdout).strip().splitlines()[-1])


def measure(folder: Path, rounds: int, work: Path, peer: bool = True) -> dict:
    import yaml

    yaml_path = work / f"{SCENE}.yaml"
    yaml_path.write_text(yaml.safe_dump(scenes.ref_scene_yaml(folder)))
    obj = str((folder / "sphere.obj").resolve())
    runs: dict[str, list[dict]] = {"mcpt cold": [], "mcpt warm": [], "mitsuba obj": [], "mitsuba scene": []}
    for r in range(rounds):
        env = dict(os.environ, MCPT_CACHE="1", MCPT_CACHE_DIR=str(work / f"cache-{r}"))
        runs["mcpt cold"].append(_child([sys.executable, "-c", _MCPT_CHILD, str(yaml_path)], env))
        runs["mcpt warm"].append(_child([sys.executable, "-c", _MCPT_CHILD, str(yaml_path)], env))
        if peer:
            for kind in ("obj", "scene"):
                runs[f"mitsuba {kind}"].append(_child([str(mitsuba.python()), "-c", _PEER_CHILD, obj,
                                                       str(mitsuba.tool().parent), kind]))
    return {k: {m: statistics.median(x[m] for x in v) for m in v[0] if isinstance(v[0][m], float)}
            | {"runs": v} for k, v in runs.items() if v}


def table(res: dict) -> str:
    mi_obj = res.get("mitsuba obj", {}).get("total")
    lines = [f"{'':14s} {'total s':>8s} {'host s':>7s} {'gl s':>6s} {'ctx s':>6s} {'cpu s':>6s} {'/ mitsuba obj':>14s}"]
    for k, v in res.items():
        ratio = f"{v['total'] / mi_obj:14.2f}" if mi_obj else f"{'':14s}"
        cols = " ".join(f"{v[c]:{w}.3f}" if c in v else " " * w
                        for c, w in (("host", 7), ("gl", 6), ("ctx", 6), ("cpu", 6)))
        lines.append(f"{k:14s} {v['total']:8.3f} {cols} {ratio}")
    return "\n".join(lines)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", type=Path, help=f"a {SCENE} folder (scene.json + OBJs)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--no-peer", action="store_true", help="mcpt only")
    ap.add_argument("--json", type=Path, help="write the figures and every run here")
    a = ap.parse_args(argv)
    peer = not a.no_peer and mitsuba.available().ok
    with tempfile.TemporaryDirectory(prefix="mcpt-setup-speed-") as tmp:
        work = Path(tmp)
        res = measure(scene_dir(a.scene, work), a.rounds, work, peer)
    print(table(res))
    if a.json:
        a.json.write_text(json.dumps(res, indent=2))


if __name__ == "__main__":
    main()

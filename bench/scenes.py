"""Scenes the benchmarks render, written as YAML next to the results (nothing here touches GL).

Every scene is the Cornell box of ``scenes/cornell-box.yaml`` (same camera, materials, light and
bounce count as the Mitsuba 3 reference), optionally with its two boxes taken out and a real mesh
from ``../shared/models`` standing on the floor in their place. Meshes are placed by a YAML
``transform`` computed from their bounding box, so every model fills about the same part of the
picture whatever its units. Past the bunny's 69k triangles the bunny is midpoint-subdivided
(bench/meshes.py): same surface, same image, 4x the triangles per level.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import yaml

from mcpt.scene.shipped import shipped

from . import meshes

CORNELL_YAML = shipped("cornell-box.yaml")
CORNELL_DIR = shipped("cornell")
# The source tree's root when this runs from a checkout (bench/ beside mcpt/), else None.
_CHECKOUT = Path(__file__).resolve().parent.parent
ROOT = _CHECKOUT if (_CHECKOUT / "pyproject.toml").is_file() else None


def shared_dir() -> Path:
    """``$MCPT_SHARED``, else ``../shared`` beside the checkout, else ``../shared`` from the
    current folder (an installed wheel run from the project folder)."""
    if "MCPT_SHARED" in os.environ:
        return Path(os.environ["MCPT_SHARED"])
    if ROOT is not None and (ROOT.parent / "shared").is_dir():
        return ROOT.parent / "shared"
    return Path.cwd().parent / "shared"


def ref_scene_yaml(scene_dir: Path) -> dict:
    """mcpt's YAML scene (as a dict) for a shared scene folder: same camera, materials, bounces."""
    sj = json.loads((Path(scene_dir) / "scene.json").read_text())
    cam = sj["camera"]
    mats, meshes = {}, []
    for o in sj["objects"]:
        name = Path(o["file"]).stem
        mats[name] = {"albedo": [float(x) for x in o["albedo"]],
                      "emission": [float(x) for x in o["emission"]]}
        meshes.append({"file": str((Path(scene_dir) / o["file"]).resolve()), "material": name})
    return {"name": sj.get("name", Path(scene_dir).name),
            "camera": {"position": cam["position"], "look_at": cam["look_at"], "up": cam["up"],
                       "vfov_deg": cam["vfov_deg"],
                       "resolution": [sj["image"]["width"], sj["image"]["height"]]},
            "render": {"spp": 1, "bounces": int(sj["integrator"]["bounces"]), "seed": 0},
            "materials": mats, "meshes": meshes}


def models_dir() -> Path:
    return shared_dir() / "models"


def cornell_reference() -> Path:
    return shared_dir() / "scenes-ref" / "cornell" / "reference.exr"


# name -> (file in models/, largest extent in scene units, rotation (x, y, z) in degrees)
MODELS = {
    "suzanne": ("suzanne.obj", 0.9, (-90.0, 0.0, 0.0)),
    "cow": ("cow.obj", 1.2, (0.0, -30.0, 0.0)),
    "teapot": ("teapot.obj", 1.1, (0.0, -20.0, 0.0)),
    "bunny": ("stanford-bunny.obj", 1.1, (0.0, 0.0, 0.0)),
}

_vertex_cache: dict = {}


def _base() -> dict:
    data = yaml.safe_load(CORNELL_YAML.read_text())
    for m in data["meshes"]:
        m["file"] = str((CORNELL_DIR.parent / m["file"]).resolve())
    return data


def cornell(boxes: bool = True) -> dict:
    """The Cornell box (36 triangles), or just its walls and light (12 triangles)."""
    data = _base()
    if not boxes:
        data["meshes"] = [m for m in data["meshes"] if "_box" not in m["file"]]
        data["name"] = "cornell-empty"
    return data


def placement(path: Path, size: float, rotate_deg=(0.0, 0.0, 0.0)) -> dict:
    """A YAML transform that rotates the mesh, scales its largest side to ``size`` and stands it
    on the floor (y = -1) in the middle of the box (the boxes' place)."""
    import numpy as np

    from mcpt.scene import Transform

    key = str(path)
    if key not in _vertex_cache:
        _vertex_cache[key] = meshes.read_obj(path)[0]
    v = _vertex_cache[key]
    s = size / float((v.max(axis=0) - v.min(axis=0)).max())
    m = Transform(rotate_deg=list(rotate_deg), scale=s).matrix()
    p = v @ m[:3, :3].T
    lo, hi = p.min(axis=0), p.max(axis=0)
    t = np.array([-0.5 * (lo[0] + hi[0]), -1.0 - lo[1], -0.1 - 0.5 * (lo[2] + hi[2])])
    return {"translate": [round(float(x), 7) for x in t],
            "rotate_deg": [float(x) for x in rotate_deg], "scale": round(s, 9)}


def with_model(model: str, subdivisions: int = 0, cache_dir: Path | None = None) -> dict:
    """The Cornell box without its boxes, ``model`` (a key of MODELS) standing on the floor."""
    file, size, rot = MODELS[model]
    src = models_dir() / file
    path = meshes.subdivided_obj(src, subdivisions, cache_dir or Path("out/bench/cache")).resolve()
    data = cornell(boxes=False)
    # Placed by the ORIGINAL mesh's vertices (subdivision does not change the bounds).
    data["meshes"].insert(0, {"file": str(path), "material": "white",
                              "transform": placement(src, size, rot)})
    data["name"] = model if subdivisions == 0 else f"{model}-sub{subdivisions}"
    return data


def with_sphere(levels: int, cache_dir: Path | None = None) -> dict:
    """The Cornell box without its boxes and a white icosphere (20 * 4**levels triangles) on the
    floor: the small counts between the Cornell box and Suzanne, where BVH and loop cross."""
    path = meshes.icosphere_obj(levels, cache_dir or Path("out/bench/cache")).resolve()
    data = cornell(boxes=False)
    data["meshes"].insert(0, {"file": str(path), "material": "white",
                              "transform": placement(path, 0.8)})
    data["name"] = f"sphere-{20 * 4**levels}"
    return data


def write(data: dict, folder: Path, name: str | None = None) -> Path:
    """Write the scene as YAML into ``folder`` and return its path (what mcpt.api.prepare takes)."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name or data.get('name', 'scene')}.yaml"
    text = "# written by bench/scenes.py\n" + yaml.safe_dump(data, sort_keys=False)
    path.write_text(text)
    return path


@dataclass(frozen=True)
class SweepScene:
    label: str
    build: tuple          # ("cornell", boxes), ("sphere", levels) or ("model", name, subdivisions)

    def scene(self, cache_dir: Path) -> dict:
        if self.build[0] == "cornell":
            return cornell(boxes=self.build[1])
        if self.build[0] == "sphere":
            return with_sphere(self.build[1], cache_dir)
        return with_model(self.build[1], self.build[2], cache_dir)


# The triangle sweep, in increasing triangle count (12 walls/light triangles come with each).
TRIANGLE_LADDER = [
    SweepScene("empty box", ("cornell", False)),        # 12
    SweepScene("cornell", ("cornell", True)),           # 36
    SweepScene("sphere 80", ("sphere", 1)),             # 92
    SweepScene("sphere 320", ("sphere", 2)),            # 332
    SweepScene("suzanne", ("model", "suzanne", 0)),     # ~512
    SweepScene("cow", ("model", "cow", 0)),             # ~5.8k
    SweepScene("teapot", ("model", "teapot", 0)),       # ~6.3k
    SweepScene("suzanne /16", ("model", "suzanne", 2)),  # ~8k
    SweepScene("bunny", ("model", "bunny", 0)),         # ~69k
    SweepScene("bunny /4", ("model", "bunny", 1)),      # ~278k
    SweepScene("bunny /16", ("model", "bunny", 2)),     # ~1.11M
]
# The full sweep goes one level further (4.4M triangles: ~210 MB of triangle texels).
TRIANGLE_LADDER_FULL = TRIANGLE_LADDER + [SweepScene("bunny /64", ("model", "bunny", 3))]

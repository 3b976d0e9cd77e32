"""Peer side of the differential harness: run BY THE PEER VENV'S PYTHON (it imports mitsuba).

    python bench/mitsuba_xml.py SCENE.xml OUT.npz --spp N --runs K --seed S [-D name=value ...]
                                [--resolution WxH]

Loads the scene with ``mi.load_file(path, **defines)`` (with ``--resolution``: through
``mi.parser``, every ``hdrfilm``'s width and height replaced before instantiation, so a published
scene whose film size is no ``<default>`` renders small; the file is not touched) and renders it ``K`` times with seeds
``S .. S+K-1`` at ``N/K`` samples each; writes the mean image and the variance of that mean
(from the spread of the K runs) to ``OUT.npz`` and prints one JSON line: timings and settings.
Not part of mcpt: bench/differential.py runs it as a subprocess (as bench/mitsuba.py does with
../shared/tools/peer_mitsuba.py, whose libLLVM finder it reuses).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

# This file's folder (bench/) holds mitsuba.py, which would shadow the real package: drop it.
sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]


def load(mi, path: str, params: dict[str, str], resolution: str | None):
    """``mi.load_file``, or with ``resolution`` the same through ``mi.parser`` with the films resized."""
    if resolution is None:
        return mi.load_file(path, **params)
    width, height = (int(v) for v in resolution.lower().split("x"))
    # What mi.load_file does (mitsuba3 src/core/python/parser.cpp): the scene's folder first in
    # the file resolver, equivalent objects and meshes merged; then the films resized.
    cfg = mi.parser.ParserConfig(mi.variant())
    cfg.merge_equivalent = cfg.merge_meshes = True
    backup = mi.file_resolver()
    resolver = mi.FileResolver(backup)
    resolver.prepend(str(Path(path).resolve().parent))
    mi.set_file_resolver(resolver)
    try:
        state = mi.parser.parse_file(cfg, path, **params)
        for node in state.nodes:
            if node.type == mi.ObjectType.Film:
                node.props["width"] = width
                node.props["height"] = height
        mi.parser.transform_all(cfg, state)
        objects = mi.parser.instantiate(cfg, state)
    finally:
        mi.set_file_resolver(backup)
    return objects[0] if isinstance(objects, list) else objects


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("out")
    ap.add_argument("--spp", type=int, required=True)
    ap.add_argument("--runs", type=int, default=4)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--tool", required=True, help="../shared/tools/peer_mitsuba.py (libLLVM finder)")
    ap.add_argument("-D", dest="defines", action="append", default=[])
    ap.add_argument("--resolution", default=None, help="WxH: override every film's size")
    a = ap.parse_args()
    sys.path.insert(0, str(Path(a.tool).parent))
    import numpy as np
    from peer_mitsuba import _import_mitsuba  # noqa: E402  (sets DRJIT_LIBLLVM_PATH)

    mi, _dr, t_import = _import_mitsuba(a.variant)
    params = dict(d.split("=", 1) for d in a.defines)
    t0 = time.perf_counter()
    scene = load(mi, a.scene, params, a.resolution)
    t_load = time.perf_counter() - t0
    per_run = max(1, a.spp // a.runs)
    images, seconds = [], 0.0
    for k in range(a.runs):
        t0 = time.perf_counter()
        img = np.array(mi.render(scene, spp=per_run, seed=a.seed + k), np.float64)[..., :3]
        seconds += time.perf_counter() - t0
        images.append(img)
    stack = np.stack(images)
    mean = stack.mean(axis=0)
    var_mean = stack.var(axis=0, ddof=1) / a.runs if a.runs > 1 else np.zeros_like(mean)
    np.savez(a.out, mean=mean, var_mean=var_mean)
    print(json.dumps({"spp": per_run * a.runs, "runs": a.runs, "render_seconds": seconds,
                      "load_seconds": t_load, "import_seconds": t_import,
                      "mitsuba_version": mi.__version__, "variant": a.variant}))


if __name__ == "__main__":
    main()

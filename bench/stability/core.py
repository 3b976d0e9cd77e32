"""The stability suite's framework: cases, outcomes, the environment and shared scene helpers."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path

import numpy as np

from mcpt.bench.stats import VAR_FLOOR_ABS, VAR_FLOOR_REL, z_test
from mcpt.gpu.pack import pack
from mcpt.scene.shipped import shipped

SPHERE_OBJ = shipped("furnace/sphere_inward.obj")
CORNELL_YAML = shipped("cornell-box.yaml")
FURNACE_YAML = shipped("furnace.yaml")
FLT_MAX = float(np.finfo(np.float32).max)


# ------------------------------------------------------------------------------------------------
# Cases
# ------------------------------------------------------------------------------------------------

@dataclass
class Outcome:
    expected: str
    measured: str
    passed: bool


@dataclass(frozen=True)
class Case:
    name: str
    group: str
    fn: Callable[[Env], Outcome]
    known: Callable[[Env], str | None] | None = None   # reason + fix when known to fail

    def known_issue(self, env: Env) -> str | None:
        return self.known(env) if self.known else None


CASES: list[Case] = []


def case(name: str, group: str, known=None):
    def register(fn):
        CASES.append(Case(name, group, fn, known))
        return fn
    return register


@dataclass
class Row:
    case: Case
    outcome: Outcome
    seconds: float
    known: str | None

    @property
    def status(self) -> str:
        if self.outcome.passed:
            return "PASS" if not self.known else "PASS (known issue fixed?)"
        return "KNOWN FAIL" if self.known else "FAIL"


def run_case(c: Case, env: Env) -> Row:
    t0 = time.perf_counter()
    try:
        out = c.fn(env)
    except Exception as exc:  # a crash is a failed case, reported in the table
        out = Outcome("(no exception)", f"{type(exc).__name__}: {exc}", False)
    return Row(c, out, time.perf_counter() - t0, c.known_issue(env))


# ------------------------------------------------------------------------------------------------
# Environment and helpers
# ------------------------------------------------------------------------------------------------

@dataclass
class Env:
    """Where cases write their generated files, and which GL back end they use."""

    workdir: Path
    gl_backend: str | None = None
    cache: dict = field(default_factory=dict)   # renders shared by several cases

    @cached_property
    def gl(self):
        from mcpt.gpu.context import shared_context

        return shared_context(self.gl_backend or os.environ.get("MCPT_GL_BACKEND"))

    @property
    def llvmpipe(self) -> bool:
        return "llvmpipe" in self.gl.renderer

    def file(self, name: str) -> Path:
        self.workdir.mkdir(parents=True, exist_ok=True)
        return self.workdir / name


def write_obj(path: Path, vertices: np.ndarray, faces: np.ndarray) -> Path:
    """A plain OBJ (``v`` and 1-based ``f`` lines), full float64 precision."""
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64) + 1
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in v.tolist()]
    lines += [f"f {a} {b} {c}" for a, b, c in f.tolist()]
    path.write_text("\n".join(lines) + "\n")
    return path


def make_scene(env: Env, name: str, *, camera: dict, meshes: list[dict], materials: dict,
               bounces: int = 8, spp: int = 16, seed: int = 0):
    """A validated Scene from plain data (JSON is YAML, so this goes through parse_scene)."""
    from mcpt.scene import parse_scene

    doc = {"name": name, "camera": camera, "render": {"spp": spp, "bounces": bounces, "seed": seed},
           "materials": materials,
           "meshes": [{**m, "file": str(m["file"])} for m in meshes]}
    return parse_scene(json.dumps(doc), env.file(f"{name}.yaml"))


def render(env: Env, scene, spp: int, seed: int = 1, *, max_random_per_tile: int | None = None,
           chunk: int = 64, **flags):
    """(RenderResult, Prepared) with per-pixel variance; the renderer is released. ``flags``:
    features by name (mcpt/gpu/features.py derive: e.g. the switches sampling="nee",
    russian_roulette=False)."""
    from mcpt.api import Options, prepare, run
    from mcpt.gpu.render import Renderer

    p = prepare(scene, gl_backend=env.gl_backend, feature_flags={"variance": True, **flags})
    try:
        if max_random_per_tile is not None:
            p.renderer.release()
            p = replace(p, renderer=Renderer(p.gl, p.features, pack(p.world, p.features),
                                             max_random_per_tile=max_random_per_tile))
        result = run(p, Options(spp=spp, seed=seed, chunk=chunk)).result
    finally:
        p.renderer.release()
    return result, p


def compare_images(a, b, spp_a: int, spp_b: int):
    """z-test of two independent renders (RenderResults) of the same scene."""
    floor = (VAR_FLOOR_ABS + VAR_FLOOR_REL * np.asarray(b.image, np.float64) ** 2) * (
        1.0 / spp_a + 1.0 / spp_b)
    return z_test(a.image, b.image, a.variance, b.variance, var_floor=floor)


def fmt(x: float) -> str:
    return f"{x:.6g}"

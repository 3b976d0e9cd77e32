"""The task a Dask worker runs: whole chunks of passes of one tile, from a scene file it reads.

Each worker process owns one GL context, created on the first task (mcpt/gpu/context.py,
``shared_context``) in one long-lived thread of this module: a GL context is current in ONE thread,
and Dask may run tasks on any thread of its pool. Workers start by spawn (Dask's default, set again
in cluster.py), so no process is ever forked after a context exists. The prepared scene (BVH,
compiled program, uploaded buffers) is kept per job, so only the first task of a render pays for it.

A task is a pure function of (job, seed, tile, first pass, stop): a retried or duplicated task
gives the same numbers, which is what lets a lost worker cost time and not pixels.
"""

from __future__ import annotations

import hashlib
import json
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..errors import McptError


class FarmError(McptError, RuntimeError):
    """A farm that cannot render this job (no Dask, scheduler unreachable, a worker with other files)."""


_GL_THREAD = ThreadPoolExecutor(max_workers=1, thread_name_prefix="mcpt-gl")
_PREPARED: dict[str, object] = {}


def job_id(job: dict) -> str:
    return hashlib.sha256(json.dumps(job, sort_keys=True, default=str).encode()).hexdigest()[:12]


def _prepared(job: dict):
    key = job_id(job)
    if key not in _PREPARED:
        from ..prepare import prepare  # the set-up of a render, not the coordinator's loop
        from ..scene.frame import job_scene  # issue #26: a frame of an animated scene
        from .state import scene_hash

        for old in list(_PREPARED.values()):  # one render at a time per worker: free the last one
            old.renderer.release()
        _PREPARED.clear()
        p = prepare(job_scene(job), overrides=tuple(job["overrides"]), bounces=job["bounces"],
                    seed=job["seed"], resolution=job["resolution"], gl_backend=job["gl_backend"],
                    features_mode=job["features_mode"], clamp=job["clamp"], sampler=job["sampler"],
                    aovs=tuple(job.get("aovs", ())))
        found = scene_hash(p.scene)
        if found != job["scene_hash"]:
            raise FarmError(f"{job['scene']} on this worker is not the scene being rendered "
                            f"(hash {found}, expected {job['scene_hash']}); "
                            "workers need the same scene files at the same path")
        if [list(t) for t in p.renderer.tiles] != [list(t) for t in job["tiles"]]:
            raise FarmError("this worker's GL limits split the image into other tiles")
        if p.renderer.samples_per_draw != job["samples_per_draw"]:
            raise FarmError(f"this worker draws {p.renderer.samples_per_draw} samples a draw, the "
                            f"render {job['samples_per_draw']}: another mcpt version")
        _PREPARED[key] = p
    return _PREPARED[key]


def _render(job, tile, first, stop, carry, chunk):
    p = _prepared(job)
    r = p.renderer
    x0, y0, w, h = r.tiles[tile]
    full_carry = None
    if carry is not None:
        full_carry = np.zeros((len(r.targets), r.height, r.width, 4), np.float32)
        full_carry[:, y0:y0 + h] = carry
    out = []
    for summed, sums in r.passes(job["seed"], first, stop, chunk=chunk, carry=full_carry,
                                 tiles=[tile]):
        out.append((summed, np.ascontiguousarray(sums[:, y0:y0 + h])))
    return out


def render_chunks(job: dict, tile: int, first: int, stop: int, carry=None, chunk: int = 64):
    """Passes ``first .. stop-1`` of tile ``tile``: a list of ``(passes summed, rows)`` read-backs,
    ``rows`` float32 (targets, tile height, width, 4), at the same passes as one process reads."""
    return _GL_THREAD.submit(_render, job, tile, first, stop, carry, chunk).result()

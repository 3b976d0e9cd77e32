"""Traversal work per ray, counted on the GPU (glsl/bvh.glsl, MCPT_COUNTERS).

A debug build of the path tracer (define MCPT_COUNTERS 1, never compiled otherwise) sums, over
every traced ray, the loop iterations, BVH node steps, triangle tests and texel fetches of
glsl/bvh.glsl's traversal into a shader storage buffer with atomics. :func:`measure` renders a
few passes with it and returns the averages per ray: the currency of speed on llvmpipe, where
every loop iteration pays for its whole body (issue #14). Counts do not depend on timing, so
two trees or two traversals compare exactly.

A measuring tool, not part of rendering: ``mcpt info --counters`` (cli/info.py) and the benchmarks
call it; the library (mcpt/) never imports it.
"""

from __future__ import annotations

import numpy as np

from mcpt.api import Options, prepare, run

#: Order of the uints in glsl/bvh.glsl's BvhCounters block.
FIELDS = ("rays", "iterations", "fetches", "node_steps", "triangle_tests", "shadow_rays",
          "batch_iterations_256", "batch_lanes")
#: Storage-buffer binding point of the counters (glsl/bvh.glsl `binding = 0`).
BINDING = 1  # 0 is the path-continuation count (glsl/path_state.glsl)


def measure(scene, *, spp: int = 1, seed: int = 0, **prepare_kwargs) -> dict:
    """Render ``spp`` passes of ``scene`` with the counters build; work per ray.

    ``prepare_kwargs`` go to :func:`mcpt.api.prepare` (resolution, bounces, gl_backend, ...).
    Returns rays traced (closest and shadow) and per ray: iterations, node_steps,
    triangle_tests, fetches (texel fetches of the traversal only, not of shading), and the SIMD
    batch's view: batch_lanes (lanes a batch runs), batch_iterations_per_ray (iterations the
    batches ran, over the rays) and lane_utilization (iterations / (lanes x batch iterations)).
    """
    flags = {**prepare_kwargs.pop("feature_flags", {}), "counters": True}
    p = prepare(scene, feature_flags=flags, **prepare_kwargs)
    try:
        buf = p.gl.ctx.buffer(np.zeros(len(FIELDS), np.uint32).tobytes())
        buf.bind_to_storage_buffer(BINDING)
        totals = np.zeros(len(FIELDS), np.float64)
        lanes = 0.0
        for i in range(spp):  # one pass at a time: 32-bit counters stay far from overflow
            run(p, Options(spp=1, seed=seed + i))
            got = np.frombuffer(buf.read(), np.uint32).astype(np.float64)
            lanes = max(lanes, got[-1])
            totals += got
            buf.write(np.zeros(len(FIELDS), np.uint32).tobytes())
        buf.release()
    finally:
        p.renderer.release()
    t = dict(zip(FIELDS, totals))
    rays = max(t["rays"], 1.0)
    batch = t["batch_iterations_256"] / 256.0
    # The share of a SIMD batch's lane slots that did traversal work (1: every lane of every
    # batch iterated as long as the slowest; llvmpipe's 8-lane batches run a loop while any lane
    # needs it, issue #23); None where the driver has no ballots to count active lanes with.
    utilization = t["iterations"] / (lanes * batch) if lanes and batch else None
    return {
        "rays": int(t["rays"]),
        "shadow_rays": int(t["shadow_rays"]),
        "passes": spp,
        "bvh": bool(p.features.bvh),
        **{f"{k}_per_ray": t[k] / rays for k in ("iterations", "node_steps", "triangle_tests", "fetches")},
        "batch_lanes": int(lanes),
        "batch_iterations_per_ray": batch / rays,
        "lane_utilization": utilization,
    }

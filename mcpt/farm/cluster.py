"""Passes on Dask distributed: a LocalCluster of N processes (``--workers N``) or an existing
cluster (``--scheduler tcp://HOST:8786``).

Tasks are keyed by (job, seed, tile, pass range); each covers whole chunks of ``CHUNK`` passes
(the last may be shorter), so its read-backs are the very float32 arrays one process reads
(mcpt/gpu/render.py, ``Renderer.passes``). The coordinator adds them in pass order into the same
:class:`Accumulator` as a one-process render: the image is bit-identical to it, whichever worker
ran which task, how often a task was retried, or in which order results came back. Dask
reschedules the tasks of a worker that died (a LocalCluster's nanny restarts it), so a lost worker
costs time, not pixels.

Workers read the scene from the same path (a shared folder on a farm) and check its content hash
against the coordinator's before the first pass.
"""

from __future__ import annotations

import os

import numpy as np

from .accumulate import CHUNK
from .worker import FarmError, job_id, render_chunks


def require_dask():
    try:
        import dask  # noqa: F401
        import distributed  # noqa: F401
    except ImportError:
        raise FarmError("--workers and --scheduler need Dask: pip install 'mcpt[farm]'") from None


def local_cluster(n: int, lp_threads: int | None = None):
    """A LocalCluster of ``n`` single-threaded worker processes (spawned). On llvmpipe each
    process also draws with LP_NUM_THREADS threads: by default the cores split between workers,
    so two workers on two cores do not fight over them."""
    import dask
    from distributed import LocalCluster

    if lp_threads is None:
        lp_threads = int(os.environ.get("LP_NUM_THREADS") or max(1, (os.cpu_count() or 1) // n))
    dask.config.set({"distributed.worker.multiprocessing-method": "spawn",
                     "distributed.scheduler.allowed-failures": 10})
    return LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                        silence_logs=40, env={"LP_NUM_THREADS": str(lp_threads)})


def job_for(p) -> dict:
    """What a worker needs to prepare the very program of ``p`` (mcpt/prepare.py Prepared)."""
    src = p.scene.source_path
    if src is None:
        raise FarmError("--workers needs a scene file (workers read it from its path)")
    from ..scene.frame import frame_job
    from .state import scene_hash

    cam = p.scene.camera
    return {"scene": str(src.resolve()), "overrides": list(p.overrides),
            "bounces": p.scene.render.bounces, "seed": p.scene.render.seed,
            "resolution": [cam.width, cam.height], "gl_backend": p.gl_backend,
            "features_mode": p.features_mode, "clamp": p.clamp, "sampler": p.features.sampler,
            "aovs": list(p.aovs),
            "scene_hash": scene_hash(p.scene), "tiles": [list(t) for t in p.renderer.tiles],
            "samples_per_draw": p.renderer.samples_per_draw,
            **frame_job(p.scene)}  # issue #26: a frame of an animated scene (mcpt/scene/frame.py)


def ranges(start: int, stop: int, chunk: int = CHUNK) -> list[tuple[int, int]]:
    """Whole chunks from ``start`` (which may be inside one: its task carries the partial)."""
    out, a = [], start
    while a < stop:
        b = min(stop, (a // chunk + 1) * chunk)
        out.append((a, b))
        a = b
    return out


def render_on_cluster(p, opts, acc, control, save_checkpoint) -> dict:
    """Draw passes ``acc.spp .. spp-1`` of ``p`` on Dask workers into ``acc`` (see the module
    docstring): on ``opts.client``, else on ``opts.scheduler``, else on a LocalCluster of
    ``opts.workers``. Returns cluster_seconds, workers and tasks."""
    import time

    from distributed import Client

    client = opts.client
    own = client is None
    cluster = None
    timing = {}
    t0 = time.perf_counter()
    if own:
        if opts.scheduler:
            try:
                client = Client(opts.scheduler, timeout="20s")
            except (OSError, TimeoutError, ValueError) as exc:
                raise FarmError(f"--scheduler {opts.scheduler}: cannot reach the Dask scheduler "
                                f"({' '.join(str(exc).split())[:200]})") from None
        else:
            cluster = local_cluster(opts.workers)
            client = Client(cluster)
    timing["cluster_seconds"] = time.perf_counter() - t0
    timing["workers"] = len(client.scheduler_info()["workers"])
    try:
        timing["tasks"] = _run(client, p, acc, control, save_checkpoint)
    finally:
        if own:
            client.close()
            if cluster is not None:
                cluster.close()
    return timing


def _run(client, p, acc, control, save_checkpoint):
    from distributed import as_completed

    r = p.renderer
    spp, seed = p.scene.render.spp, p.scene.render.seed
    job = job_for(p)
    jid = job_id(job)
    tiles = r.tiles
    todo = ranges(acc.spp, spp, acc.chunk)
    futures = {}
    for first, stop in todo:
        for ti, (_x0, y0, _w, h) in enumerate(tiles):
            carry = None
            if first == acc.spp and acc.partial is not None:
                carry = np.ascontiguousarray(acc.partial[:, y0:y0 + h])
            key = f"mcpt-{jid}-s{seed}-t{ti}-p{first}-{stop}"
            fut = client.submit(render_chunks, job, ti, first, stop, carry, acc.chunk, key=key,
                                pure=False, retries=3)
            futures[fut] = (first, stop, ti)
    arrived: dict[int, dict[int, list]] = {}
    pending = dict(futures)
    try:
        for fut in as_completed(list(futures)):
            first, stop, ti = pending.pop(fut)
            arrived.setdefault(first, {})[ti] = fut.result()
            # Add, in pass order, every range whose tiles have all arrived.
            while todo and len(arrived.get(todo[0][0], {})) == len(tiles):
                a, b = todo.pop(0)
                parts = arrived.pop(a)
                reads = [summed for summed, _ in parts[0]]
                for i, summed in enumerate(reads):
                    sums = np.zeros((len(r.targets), r.height, r.width, 4), np.float32)
                    for tj, (_x0, y0, _w, h) in enumerate(tiles):
                        sums[:, y0:y0 + h] = parts[tj][i][1]
                    acc.add(summed, sums)
                action = control.tick(acc.spp, b - a)
                if action == "checkpoint":
                    save_checkpoint()
                elif action == "stop":
                    return len(futures) - len(pending)
        return len(futures)
    finally:
        for fut in pending:
            fut.cancel()

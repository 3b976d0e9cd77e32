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

import contextlib
import logging
import os
import signal
import threading
from collections import deque

import numpy as np

from .accumulate import CHUNK
from .worker import FarmError, job_id, render_chunks


def require_dask():
    try:
        import dask  # noqa: F401
        import distributed  # noqa: F401
    except ImportError:
        raise FarmError("--workers and --scheduler need Dask: pip install 'mcpt[farm]'") from None


#: Seconds the scheduler's address may take to accept a TCP connection (check_scheduler).
PROBE_SECONDS = 3.0


def check_scheduler(address: str, timeout: float = PROBE_SECONDS) -> None:
    """``--scheduler ADDRESS`` checked before any work, one line each (issue #24 items 17, 19):
    empty; a scheme other than tcp:// (tls:// needs certificates mcpt takes no options for: it
    was a TypeError); a bad port (99999); and the address probed with a plain TCP connect, so a
    refused connection or an unknown host says so at once (Dask's client retried for 20 s and
    said "Timed out")."""
    import socket
    from urllib.parse import urlsplit

    where = f"--scheduler {address!r}"
    if not address.strip():
        raise FarmError(f"{where}: empty; give the Dask scheduler's address, e.g. tcp://HOST:8786")
    scheme, sep, rest = address.strip().partition("://")
    if not sep:
        scheme, rest = "tcp", address.strip()
    if scheme.lower() != "tcp":
        raise FarmError(f"{where}: only tcp:// scheduler addresses are supported, not {scheme}://")
    try:
        parts = urlsplit(f"tcp://{rest}")
        host, port = parts.hostname, parts.port or 8786
    except ValueError as exc:  # "Port out of range 0-65535", "Port could not be cast to integer"
        raise FarmError(f"{where}: {exc}; expected tcp://HOST:PORT") from None
    if not host or parts.path not in ("", "/") or not 0 < port < 65536:
        raise FarmError(f"{where}: expected tcp://HOST:PORT (PORT 1 to 65535)")
    try:
        socket.create_connection((host, port), timeout=timeout).close()
    except ConnectionRefusedError:
        raise FarmError(f"{where}: connection refused (no Dask scheduler listening on {host}:{port})") from None
    except socket.gaierror as exc:
        raise FarmError(f"{where}: unknown host {host!r} ({exc.strerror})") from None
    except TimeoutError:
        raise FarmError(f"{where}: no answer from {host}:{port} within {timeout:g} s") from None
    except OSError as exc:
        raise FarmError(f"{where}: cannot connect to {host}:{port} ({exc.strerror or exc})") from None


#: Resident memory of one worker process (measured: 177 MB each for two workers drawing the
#: Cornell box at 64x64 on llvmpipe; Python, Dask, Mesa and the prepared scene), with room to spare.
WORKER_BYTES = 256 * 2**20


def check_workers(n: int) -> None:
    """``--workers N`` within this machine's cores and memory, else one line (issue #24: 1000
    workers printed thousands of "can't start new thread" lines and ignored SIGTERM)."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    from ..gpu.host_memory import available_bytes

    free = available_bytes()
    by_memory = max(1, free // WORKER_BYTES) if free is not None else n
    most = min(cores, by_memory)
    if n > most:
        mem = f", {free / 2**30:.1f} GiB of memory available at {WORKER_BYTES >> 20} MiB a worker" if free else ""
        raise FarmError(f"--workers {n}: at most {most} on this machine ({cores} cores{mem}); "
                        "a bigger farm is --scheduler tcp://HOST:8786")


#: GL renderers that draw on the CPU (Mesa): local workers split its cores, not a GPU.
SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swrast")


def shared_gpu_note(renderer: str, workers: int) -> str | None:
    """One line when ``workers`` local processes would all draw on the one hardware GPU behind
    ``renderer`` (the GL_RENDERER string): on an NVIDIA H200, 16 processes sharing the GPU read
    back targets no shader had written while long draws ran (bench/RESULTS.md, the H200
    section), which no check of ours can see. None on a software renderer or with one worker."""
    if workers <= 1 or any(s in renderer.lower() for s in SOFTWARE_RENDERERS):
        return None
    return (f"--workers {workers}: every worker draws on the one GPU ({renderer}); processes "
            "sharing a GPU have lost draws silently during long draws: use one worker per GPU "
            "(--scheduler, each worker with its own GLCONTEXT_DEVICE_INDEX)")


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
    with _children_ignore_sigint():
        return LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                            dashboard_address=None, silence_logs=_dask_log_level(),
                            env={"LP_NUM_THREADS": str(lp_threads)})


def _dask_log_level() -> int:
    """Dask's own log lines (a lost worker, a closed comm, their tracebacks) only with -vv
    (issue #24): the coordinator reports what matters in one line."""
    return logging.DEBUG if logging.getLogger("mcpt").isEnabledFor(logging.DEBUG) else logging.CRITICAL + 10


@contextlib.contextmanager
def _children_ignore_sigint():
    """Worker processes started with SIGINT ignored (inherited through exec, and Python then
    installs no KeyboardInterrupt handler): Ctrl-C reaches the whole process group, and only the
    coordinator should act on it (issue #24: each worker printed a 33-line traceback and the
    scheduler's connection broke). The coordinator stops them when it closes the cluster."""
    main = threading.current_thread() is threading.main_thread()
    old = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    try:
        yield
    finally:
        if main:
            signal.signal(signal.SIGINT, old)


@contextlib.contextmanager
def _quiet_dask():
    """This process's Dask and asyncio loggers held at _dask_log_level() during a farm render."""
    loggers = [logging.getLogger(name) for name in ("distributed", "asyncio", "tornado")]
    old = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(_dask_log_level())
    try:
        yield
    finally:
        for lg, level in zip(loggers, old):
            lg.setLevel(level)


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
            "scene_hash": p.scene_hash or scene_hash(p.scene), "tiles": [list(t) for t in p.renderer.tiles],
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
    with _quiet_dask():
        return _render_on_cluster(p, opts, acc, control, save_checkpoint)


def _render_on_cluster(p, opts, acc, control, save_checkpoint) -> dict:
    import time

    from distributed import Client

    client = opts.client
    own = client is None
    cluster = None
    timing = {}
    t0 = time.perf_counter()
    if own:
        if opts.scheduler is not None:
            check_scheduler(opts.scheduler)
            try:
                client = Client(opts.scheduler, timeout="20s")
            except (OSError, TimeoutError, ValueError) as exc:
                raise FarmError(f"--scheduler {opts.scheduler}: cannot reach the Dask scheduler "
                                f"({' '.join(str(exc).split())[:200]})") from None
        else:
            note = shared_gpu_note(p.renderer.gl.renderer, opts.workers)
            if note:
                logging.getLogger("mcpt").warning(note)
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


#: Tasks in flight per worker. Enough to keep each worker busy while results travel back; few
#: enough that starting and stopping stay quick: submitting all 4 688 tasks of a 300 000-spp job at
#: once took 5.4 s before the first pass, and cancelling them one by one on Ctrl-C 17 s (measured
#: on this 2-core machine; tests/test_hardening.py item 10).
IN_FLIGHT_PER_WORKER = 4


def _run(client, p, acc, control, save_checkpoint):
    from distributed import wait

    r = p.renderer
    spp, seed = p.scene.render.spp, p.scene.render.seed
    job = job_for(p)
    jid = job_id(job)
    tiles = r.tiles
    start = acc.spp
    todo = ranges(start, spp, acc.chunk)
    queue = deque((first, stop, ti) for first, stop in todo for ti in range(len(tiles)))
    pending: dict = {}
    submitted = 0

    def submit_more():
        nonlocal submitted
        if not queue:  # all submitted: no need to ask the scheduler anything
            return
        # Counted again each time: workers may join a --scheduler cluster while it runs.
        workers = max(1, len(client.scheduler_info()["workers"]))
        window = max(len(tiles), IN_FLIGHT_PER_WORKER * workers)
        while queue and len(pending) < window:
            first, stop, ti = queue.popleft()
            carry = None
            if first == start and acc.partial is not None:  # only the first range carries one
                _x0, y0, _w, h = tiles[ti]
                carry = np.ascontiguousarray(acc.partial[:, y0:y0 + h])
            key = f"mcpt-{jid}-s{seed}-t{ti}-p{first}-{stop}"
            fut = client.submit(render_chunks, job, ti, first, stop, carry, acc.chunk, key=key,
                                pure=False, retries=3)
            pending[fut] = (first, stop, ti)
            submitted += 1

    arrived: dict[int, dict[int, list]] = {}
    submit_more()
    try:
        while pending:
            # Waits of at most 0.5 s, so that a stop signal acts at once (issue #24: it waited for
            # the next whole range, seconds); the tasks still out are cancelled below.
            try:
                done = wait(list(pending), timeout=0.5, return_when="FIRST_COMPLETED").done
            except TimeoutError:  # dask's TimeoutError is the builtin one
                done = set()
            if control.signals.stopped and not done:
                control.tick(acc.spp, 0)
                return submitted - len(pending)
            for fut in done:
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
                        return submitted - len(pending)
            submit_more()
        return submitted
    finally:
        if pending:  # one message to the scheduler, not one per task
            client.cancel(list(pending))

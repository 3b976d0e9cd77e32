"""Independent numpy jobs on every core (issue #23: a 10^6-triangle set-up on 2 cores).

numpy releases the GIL inside most of its loops (sorting, gathers, ufuncs over large arrays), so
threads run such jobs side by side. :func:`ordered` returns the jobs' results in the order of
their inputs, so a caller that joins them in that order gets the sequential result, bit for bit,
whichever thread ran what. One pool per process, made on first use; a job that calls
:func:`ordered` itself runs those jobs in its own thread (waiting for the pool it occupies could
wait forever).
``MCPT_THREADS`` sets the threads (default 0: every core; 1: everything runs in the calling thread).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor

_POOL: ThreadPoolExecutor | None = None
_LOCK = threading.Lock()
_PREFIX = "mcpt-job"


def workers() -> int:
    """Threads to use: ``MCPT_THREADS`` if set, else 0 = the cores this process may run on.
    Every core by default since the BVH's row splits joined the OBJ reader's blocks (stop 34,
    10^6-triangle set-up, fresh processes alternating 6 rounds on two quiet cores: cold 3.00 s
    against 3.20 s with one thread, medians, at ~1.2x the CPU; warm 0.20-0.22 against 0.21-0.27 s;
    bench/RESULTS.md). Stop 30 had measured no wall gain (4.71 against 4.90 s) and kept one."""
    raw = os.environ.get("MCPT_THREADS", "0")
    try:
        n = int(raw)
    except ValueError:
        n = 1
    if n <= 0:
        n = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return max(1, n)


def _pool() -> ThreadPoolExecutor:
    global _POOL
    with _LOCK:
        if _POOL is None:
            _POOL = ThreadPoolExecutor(workers(), thread_name_prefix=_PREFIX)
        return _POOL


def _forget_pool() -> None:
    """In a forked child: the parent's pool threads do not exist here, so a job queued on its
    pool would wait forever; the child makes its own on first use."""
    global _POOL, _LOCK
    _POOL, _LOCK = None, threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pool)


def ordered(fn: Callable, items: Iterable) -> list:
    """``[fn(x) for x in items]``, the calls spread over the pool's threads; the first exception
    (in input order) is raised after the calls not yet started are cancelled."""
    items = list(items)
    inside = threading.current_thread().name.startswith(_PREFIX)  # a job's own jobs run in it
    if len(items) < 2 or workers() == 1 or inside:
        return [fn(x) for x in items]
    futures = [_pool().submit(fn, x) for x in items]
    try:
        return [f.result() for f in futures]
    finally:
        for f in futures:
            f.cancel()


def side_by_side(*jobs: Callable) -> list:
    """The results of the calls ``job()``, in order, the calls spread over the pool's threads
    (:func:`ordered` of independent steps)."""
    return ordered(lambda job: job(), jobs)


#: Fewer rows than this are one chunk (a thread's hand-off costs more than it saves).
MIN_CHUNK_ROWS = 1 << 16


def row_chunks(n: int, min_rows: int = MIN_CHUNK_ROWS) -> list[slice]:
    """``n`` rows cut into one slice per thread (one slice below ``2 * min_rows`` rows): for work
    done row by row, whose result does not depend on where the rows are cut."""
    parts = max(1, min(workers(), n // min_rows))
    return [slice(n * i // parts, n * (i + 1) // parts) for i in range(parts)]

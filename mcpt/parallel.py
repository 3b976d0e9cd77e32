"""Independent numpy jobs on every core (issue #23: a 10^6-triangle set-up on 2 cores).

numpy releases the GIL inside most of its loops (sorting, gathers, ufuncs over large arrays), so
threads run such jobs side by side. :func:`ordered` returns the jobs' results in the order of
their inputs, so a caller that joins them in that order gets the sequential result, bit for bit,
whichever thread ran what. One pool per process, made on first use; a job that calls
:func:`ordered` itself runs those jobs in its own thread (waiting for the pool it occupies could
wait forever).
``MCPT_THREADS`` sets the threads (default 1: everything runs in the calling thread; 0: every core).
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
    """Threads to use: ``MCPT_THREADS`` if set (0: the cores this process may run on), else 1.
    One by default: on two free cores the threads bought no wall time and cost CPU (10^6-triangle
    set-up, fresh processes alternating: cold 4.71 s wall / 5.84 CPU-s with two threads against
    4.90 / 5.22 with one; warm 0.30 against 0.25 s; bench/RESULTS.md)."""
    raw = os.environ.get("MCPT_THREADS", "1")
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

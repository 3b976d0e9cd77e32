"""mcpt/parallel.py: jobs on every core give the results in input order, the first error
in input order, and MCPT_THREADS=1 runs them in the calling thread."""

from __future__ import annotations

import multiprocessing
import os
import threading
import time

import pytest

from mcpt import parallel


def test_results_come_in_input_order_whichever_job_ends_first():
    def slow_first(i):
        time.sleep(0.02 if i == 0 else 0.0)  # job 0 ends last
        return i * i

    assert parallel.ordered(slow_first, range(6)) == [i * i for i in range(6)]


def test_the_first_error_in_input_order_is_raised(monkeypatch):
    monkeypatch.setenv("MCPT_THREADS", "2")

    def fail(i):
        if i == 3:
            time.sleep(0.02)
            raise KeyError(i)
        if i == 5:
            raise ValueError(i)  # raised earlier in time, later in order
        return i

    with pytest.raises(KeyError):
        parallel.ordered(fail, range(8))


def test_one_thread_runs_the_jobs_in_the_calling_thread(monkeypatch):
    monkeypatch.setenv("MCPT_THREADS", "1")
    where = parallel.ordered(lambda _: threading.current_thread(), range(3))
    assert where == [threading.current_thread()] * 3
    assert parallel.workers() == 1


def test_jobs_of_a_job_run_in_its_thread(monkeypatch):
    """A job that spreads jobs of its own does not wait for the pool it occupies."""
    monkeypatch.setenv("MCPT_THREADS", "2")
    inner = parallel.ordered(lambda i: parallel.ordered(lambda j: (i, j), range(3)), range(4))
    assert inner == [[(i, j) for j in range(3)] for i in range(4)]


def _square_in_child(queue):
    queue.put(parallel.ordered(lambda i: i * i, range(4)))


@pytest.mark.skipif(not hasattr(os, "fork"), reason="fork only")
def test_a_forked_child_makes_its_own_pool(monkeypatch):
    """A child forked after the pool exists (multiprocessing's default on Linux) cannot use the
    parent's threads: its jobs would wait forever."""
    monkeypatch.setenv("MCPT_THREADS", "2")
    assert parallel.ordered(lambda i: i, range(4)) == [0, 1, 2, 3]  # the parent's pool exists
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=_square_in_child, args=(queue,))
    child.start()
    child.join(20)
    alive = child.is_alive()
    if alive:
        child.kill()
    assert not alive and queue.get(timeout=1) == [0, 1, 4, 9]


def test_every_core_is_the_default(monkeypatch):
    monkeypatch.delenv("MCPT_THREADS", raising=False)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert parallel.workers() == max(1, cores)
    monkeypatch.setenv("MCPT_THREADS", "0")
    assert parallel.workers() == max(1, cores)

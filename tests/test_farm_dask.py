"""Renders on Dask distributed (issue #11): a 2-worker LocalCluster gives the one-process image
bit for bit, also when a worker process is killed in the middle of the render.

One LocalCluster (two spawned single-threaded workers, LP_NUM_THREADS=1) serves the module; the
scene is tests/test_farm.py's lit floor and box at 12x10.
"""

from __future__ import annotations

import os
import signal
import time

import pytest

pytest.importorskip("distributed")

from mcpt.farm.signals import StopSignals  # noqa: E402
from mcpt.render import Options  # noqa: E402
from mcpt.render import render as run

from . import test_farm  # noqa: E402
from .test_farm import same_bits  # noqa: E402

folder = test_farm.folder  # the fixture: a scene folder as the cwd


@pytest.fixture(scope="module")
def client():
    from distributed import Client

    from mcpt.farm.cluster import local_cluster

    cluster = local_cluster(2, lp_threads=1)
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


def render(folder, out, spp, client=None, progress=None, seed=7, sampler=None):
    opts = Options([str(folder / out)], spp=spp, seed=seed, client=client, progress=progress,
                   sampler=sampler)
    outcome = run(folder / "scene.yaml", opts, StopSignals())
    assert outcome.result.spp == spp
    return outcome.result.image


def test_two_workers_equal_one_process_bit_for_bit(folder, client):
    spp = 64 * 3 + 19  # three whole chunks and a short one
    one = render(folder, "one.exr", spp)
    farm = render(folder, "farm.exr", spp, client=client)
    assert same_bits(one, farm)
    assert len(client.scheduler_info()["workers"]) == 2


def test_a_killed_worker_costs_time_not_pixels(folder, client):
    """Kill one worker process (SIGKILL) after the first chunk arrived: Dask re-runs its tasks
    elsewhere (the nanny restarts it) and the image is still the one-process image."""
    spp = 64 * 8
    killed = []

    def kill_one(done, total, run_, seconds):
        if not killed:
            pids = client.run(os.getpid)
            victim = sorted(pids.values())[0]
            os.kill(victim, signal.SIGKILL)
            killed.append(victim)

    farm = render(folder, "farm.exr", spp, client=client, progress=kill_one, seed=11)
    assert killed
    # The scheduler may still list the dead worker for a moment after the nanny's new one joined
    # (a broadcast to it then fails): wait until two live workers answer and none is the victim.
    deadline = time.monotonic() + 60
    while True:
        pids = client.run(os.getpid, on_error="ignore")
        if len(pids) == 2 or time.monotonic() > deadline:
            break
        time.sleep(0.2)
    assert len(pids) == 2 and killed[0] not in pids.values()
    one = render(folder, "one.exr", spp, seed=11)
    assert same_bits(one, farm)


@pytest.mark.parametrize("sampler, resumed", [("sobol", 64), ("independent", 100)])
def test_farm_resumes_a_one_process_checkpoint_bit_for_bit(folder, client, sampler, resumed):
    """A checkpoint that ended inside a chunk (100 passes), resumed on the farm to 200; the image
    equals one uninterrupted 200-pass render. sobol: its last draw held passes 64..99, off the
    draw grid (64 a draw here), so the farm draws 64..127 again. independent (one pass a draw):
    the first task carries the unfinished chunk."""
    opts = Options([str(folder / "c.exr")], spp=100, checkpoint=1e6, sampler=sampler)
    assert run(folder / "scene.yaml", opts, StopSignals()).checkpoint is not None
    opts = Options([str(folder / "c.exr")], spp=200, resume=True, client=client, sampler=sampler)
    out = run(folder / "scene.yaml", opts, StopSignals())
    assert out.resumed_from == resumed and out.result.spp == 200
    assert same_bits(out.result.image, render(folder, "ref.exr", 200, sampler=sampler))


def test_a_long_render_keeps_a_short_queue_and_stops_quickly(folder, client):
    """A 12 800-pass job (200 chunks) had all 200 tasks submitted before the first pass and
    cancelled one message each on a stop: 5.4 s before a 300 000-spp job started and 17 s to end
    it after Ctrl-C (tests/test_hardening.py item 10). The scheduler now holds a window of tasks
    a worker, and a stop leaves none of them running."""
    from mcpt.farm.cluster import IN_FLIGHT_PER_WORKER

    def held(dask_scheduler):
        return len(dask_scheduler.tasks)

    signals, seen = StopSignals(), []

    def stop_at_first_progress(done, total, run_, seconds):
        if not seen:
            seen.append(client.run_on_scheduler(held))
            signals.signum = signal.SIGTERM  # what the handler records for a stop signal

    opts = Options([str(folder / "long.exr")], spp=64 * 200, client=client,
                   progress=stop_at_first_progress)
    out = run(folder / "scene.yaml", opts, signals)
    assert seen and 0 < seen[0] < 3 * IN_FLIGHT_PER_WORKER * 2, seen  # 200 before
    assert out.result is None or out.result.spp < 64 * 200
    # Cancelling is a message the scheduler acts on a moment later (a task already drawing ends
    # first): wait for it, up to a generous bound, rather than reading its state at once.
    def to_run(dask_scheduler):
        return sorted(t.state for t in dask_scheduler.tasks.values()
                      if t.state not in ("memory", "released", "forgotten"))

    deadline = time.monotonic() + 60.0
    while (states := client.run_on_scheduler(to_run)) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert states == [], states  # nothing left to run

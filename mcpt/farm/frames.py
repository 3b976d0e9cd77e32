"""A frame sequence (issue #26, mcpt/sequence.py) on Dask: one task per frame still to do.

A task renders one whole frame on a worker, as one process would (mcpt/sequence.py FrameMaker:
a worker keeps the prepared scene between the frames it gets when only the camera moves), and
writes the frame's images itself, atomically, to the same paths (a shared folder on a farm). So
a farm sequence is bit for bit the one-process sequence; a lost worker's frame is retried
elsewhere (Dask ``retries``) and a crashed coordinator's rerun renders only the frames missing.
When a single frame is left to do, its pass ranges are spread over the workers instead
(mcpt/farm/cluster.py, the job naming the frame: mcpt/scene/frame.py ``job_scene``); otherwise
a frame's passes stay on one worker.
"""

from __future__ import annotations

from ..sequence import FrameMaker, FrameReport, SequenceOutcome, base_scene, plan
from .cluster import local_cluster, require_dask
from .signals import StopSignals
from .state import scene_hash
from .worker import _GL_THREAD, FarmError, job_id

_MAKERS: dict = {}
# Options a worker needs to render a frame as the coordinator would (mcpt/render.py Options).
_FIELDS = ("outputs", "spp", "bounces", "seed", "resolution", "gl_backend", "features_mode",
           "sampler", "clamp", "exposure", "aovs", "denoise", "overrides")


def _maker(job: dict) -> FrameMaker:
    from ..render import Options

    key = job_id(job)
    if key not in _MAKERS:
        for old in _MAKERS.values():  # one sequence at a time per worker
            old.release()
        _MAKERS.clear()
        opts = Options(**job["opts"])
        base = base_scene(job["scene"], opts)
        if scene_hash(base) != job["scene_hash"]:
            raise FarmError(f"{job['scene']} on this worker is not the scene being rendered; "
                            "workers need the same scene files at the same path")
        _MAKERS[key] = FrameMaker(base, opts)
    return _MAKERS[key]


def _render(job: dict, frame: int, paths: list) -> dict:
    rep, _ = _maker(job).render(frame, paths, StopSignals())
    return vars(rep)


def render_frame(job: dict, frame: int, paths: list) -> dict:
    """The Dask task: frame ``frame`` of the job's scene written to ``paths``; its FrameReport."""
    return _GL_THREAD.submit(_render, job, frame, paths).result()


def sequence_on_cluster(scene_file, opts, frames=None, signals: StopSignals | None = None,
                        on_frame=None) -> SequenceOutcome:
    """``mcpt render --frames ... --workers N`` (or ``--scheduler``, or ``opts.client``)."""
    from distributed import Client

    require_dask()
    signals = signals if signals is not None else StopSignals()
    base, frames, paths, todo = plan(scene_file, opts, frames)
    if base.source_path is None:
        raise FarmError("a farm sequence needs a scene file (workers read it from its path)")
    out = SequenceOutcome(frames, skipped=[f for f in frames if f not in todo])
    out.rebuilt = FrameMaker(base, opts).rebuild
    client, cluster = opts.client, None
    if client is None:
        cluster = None if opts.scheduler else local_cluster(opts.workers)
        client = Client(opts.scheduler or cluster, timeout="20s")
    try:
        if len(todo) == 1:  # one frame: its pass ranges over the workers (mcpt/farm/cluster.py)
            maker = FrameMaker(base, opts, client)
            try:
                rep, signum = maker.render(todo[0], paths[todo[0]], signals)
            finally:
                maker.release()
            _arrived(out, [] if rep is None else [rep], signum if rep is None else None, on_frame)
        elif todo:
            _by_frame(client, base, opts, todo, paths, signals, out, on_frame)
    finally:
        if opts.client is None:
            client.close()
            if cluster is not None:
                cluster.close()
    out.rendered.sort(key=lambda r: r.frame)
    return out


def _arrived(out: SequenceOutcome, reports: list, signum, on_frame) -> None:
    for rep in reports:
        out.rendered.append(rep)
        if on_frame is not None:
            on_frame(rep)
    if signum is not None:
        out.stopped_by, out.interrupted = "signal", signum


def _by_frame(client, base, opts, todo, paths, signals, out, on_frame) -> None:
    """One task per frame, each written by its worker; results reported as they arrive."""
    from distributed import as_completed

    settings = {k: getattr(opts, k) for k in _FIELDS}
    settings["outputs"] = [str(o) for o in settings["outputs"]]
    job = {"scene": str(base.source_path.resolve()), "opts": settings, "scene_hash": scene_hash(base)}
    jid = job_id(job)
    futures = [client.submit(render_frame, job, f, [str(x) for x in paths[f]], key=f"mcpt-{jid}-f{f}",
                             pure=False, retries=3) for f in todo]
    try:
        for fut in as_completed(futures):
            # a stop signal: the frames written stay; a rerun does the rest
            _arrived(out, [FrameReport(**fut.result())], signals.signum if signals.stopped else None,
                     on_frame)
            if signals.stopped:
                break
    finally:
        for fut in futures:
            fut.cancel()

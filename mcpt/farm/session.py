"""One render from start (or a checkpoint) to images, with a time budget, periodic checkpoints and
stop signals: the loop behind ``mcpt render`` (the library's one-shot call is mcpt.api.render_scene).

Passes come from ``Renderer.passes`` (one process) or from Dask tasks (mcpt/farm/cluster.py); both
feed an :class:`Accumulator`, so where the render stops, resumes or runs changes no bit.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path

from ..api import header_keys, metadata, prepare
from ..errors import McptError
from ..output.image import write_image
from ..output.layers import computed as computed_aovs
from ..output.layers import finish
from . import state as st
from .accumulate import Accumulator
from .signals import StopSignals

log = logging.getLogger("mcpt")


class ResumeError(McptError, ValueError):
    pass


@dataclass
class Options:
    outputs: list
    spp: int | None = None
    bounces: int | None = None
    seed: int | None = None
    resolution: tuple | None = None
    gl_backend: str | None = None
    features_mode: str = "scene"
    sampler: str | None = None            # None: the default (mcpt/gpu/features.py SAMPLERS[0])
    clamp: float | None = None
    exposure: float = 0.0
    aovs: tuple = ()                      # EXR layers (mcpt/gpu/aov.py AOVS), in canonical order
    denoise: bool = False                 # OIDN on the beauty (biased); computes albedo + normal
    time_budget: float | None = None      # seconds of wall time from ``started``
    checkpoint: float | None = None       # seconds between checkpoints
    resume: bool = False
    first_pass: int = 0                   # render passes first_pass .. spp-1 (a pass range)
    overrides: tuple = ()                 # -D KEY=VALUE
    workers: int | None = None
    scheduler: str | None = None
    client: object = None                 # a distributed.Client to use (tests, notebooks)
    progress: object = None               # progress(done, total, passes_this_run, seconds)
    started: float = field(default_factory=time.perf_counter)


@dataclass
class Outcome:
    result: object                        # RenderResult of the passes done
    meta: dict
    spp_requested: int
    interrupted: int | None = None        # the signal number, when one stopped the render
    checkpoint: Path | None = None
    resumed_from: int = 0
    written: list = field(default_factory=list)
    stopped_by: str | None = None         # "signal", "time" or None (all passes done)
    farm: dict = field(default_factory=dict)  # cluster_seconds, workers, tasks (Dask renders)


class Control:
    """Asked after every pass: progress, and whether to stop (signal, time) or pause (checkpoint)."""

    def __init__(self, opts: Options, signals: StopSignals, spp: int, samples_per_draw: int = 1,
                 chunk: int = 64):
        self.opts, self.signals, self.spp = opts, signals, spp
        self.samples_per_draw, self.chunk = samples_per_draw, chunk
        self.t_run = time.perf_counter()
        self.last_checkpoint = self.t_run
        self.passes_run = 0
        self.stop: str | None = None

    def tick(self, done: int, new_passes: int = 1) -> str | None:
        """``done`` passes of the render exist; returns 'stop', 'checkpoint' or None."""
        first = self.passes_run == 0
        self.passes_run += new_passes
        now = time.perf_counter()
        if first:
            self._warn_if_long(done, now)
        if self.opts.progress is not None:
            self.opts.progress(done, self.spp, self.passes_run, now - self.t_run)
        per_pass = (now - self.t_run) / max(self.passes_run, 1)
        if self.signals.stopped:
            self.stop = "signal"
        elif (self.opts.time_budget is not None and done < self.spp
              and now - self.opts.started + per_pass * self.next_draw(done) > self.opts.time_budget):
            # Stop before the draw that would end past the budget: ends within one draw of it.
            self.stop = "time"
        if self.stop:
            return "stop"
        if self.opts.checkpoint is not None and now - self.last_checkpoint >= self.opts.checkpoint:
            return "checkpoint"
        return None

    def next_draw(self, done: int) -> int:
        """Passes the draw after pass ``done`` holds (mcpt/gpu/render.py: on the global grid)."""
        spd, chunk = self.samples_per_draw, self.chunk
        return max(1, min(spd - done % spd, chunk - done % chunk, self.spp - done))

    def _warn_if_long(self, done: int, now: float) -> None:
        """After the first draw: say so when the whole render would take longer than an hour at
        the speed measured here (issue #10: 2^40 spp used to run until killed, silently)."""
        per_pass = (now - self.t_run) / max(self.passes_run, 1)
        left = per_pass * (self.spp - done)
        if left > LONG_RENDER_SECONDS and self.opts.time_budget is None:
            log.warning("%d spp will take about %s at %.3g s a pass measured here; --time SECONDS "
                        "bounds it, --checkpoint SECONDS keeps what is done", self.spp,
                        _duration(left), per_pass)


#: A render projected to take longer than this (seconds) is announced with a warning.
LONG_RENDER_SECONDS = 3600.0


def _duration(seconds: float) -> str:
    for unit, size in (("years", 365.25 * 86400), ("days", 86400), ("hours", 3600)):
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds / 60:.3g} minutes"


def header(meta: dict, record: dict, spp_requested: int, first_pass: int = 0) -> dict:
    """EXR header keys: the render's metadata plus the record ``mcpt merge`` and resume compare.
    ``mcpt:spp`` is the passes the image holds, ``mcpt:first_pass`` the first of them."""
    return header_keys({**meta, **record, "spp_requested": spp_requested, "first_pass": first_pass})


def run(scene_file, opts: Options, signals: StopSignals) -> Outcome:
    from ..scene import load_scene

    if opts.denoise:
        from ..output.denoise import version

        version()  # no denoiser: one clear error before minutes of rendering
    scene = load_scene(scene_file, overrides=opts.overrides) if opts.overrides else scene_file
    p = prepare(scene, spp=opts.spp, bounces=opts.bounces, seed=opts.seed,
                resolution=opts.resolution, gl_backend=opts.gl_backend,
                features_mode=opts.features_mode, clamp=opts.clamp, sampler=opts.sampler,
                aovs=computed_aovs(opts.aovs, opts.denoise))
    if hasattr(opts.progress, "pixels"):
        opts.progress.pixels = p.scene.camera.width * p.scene.camera.height
    try:
        return _run(p, opts, signals)
    finally:
        p.renderer.release()


def _run(p, opts: Options, signals: StopSignals) -> Outcome:
    r = p.renderer
    spp, seed = p.scene.render.spp, p.scene.render.seed
    record = st.settings(p.scene, features_mode=opts.features_mode, clamp=opts.clamp,
                         sampler=p.features.sampler, aovs=computed_aovs(opts.aovs, opts.denoise),
                         samples_per_draw=r.samples_per_draw)
    state_file = st.state_path(opts.outputs[0])
    acc = Accumulator.empty(len(r.targets), r.height, r.width)
    if opts.first_pass:
        _check_range(opts, spp, acc.chunk)
        acc.done = opts.first_pass  # passes before it belong to another render of this seed
    if opts.resume:
        acc, found = st.load(state_file)
        # aov_targets is recorded only when there are some: compare it both ways.
        targets = [{"aov_targets": d.get("aov_targets", "none")} for d in (record, found)]
        why = st.mismatch(record, found) or st.mismatch(*targets)
        if why:
            raise ResumeError(f"{state_file}: cannot resume: {why}")
        if acc.complete.shape[0] != len(r.targets):  # a checkpoint from before AOVs were recorded
            raise ResumeError(f"{state_file}: cannot resume: it holds {acc.complete.shape[0]} "
                              f"accumulation targets, this render {len(r.targets)} (other --aov)")
        if acc.done > spp:
            raise ResumeError(f"{state_file}: cannot resume: the checkpoint has {acc.done} passes, "
                              f"more than the {spp} asked for")
        if acc.done < spp:
            acc.rewind_to_draw_grid(r.samples_per_draw)
    resumed_from = acc.done
    control = Control(opts, signals, spp, r.samples_per_draw, acc.chunk)
    timing = {"random": 0.0}
    saved = []

    def seconds():
        return time.perf_counter() - control.t_run

    def save_checkpoint():
        with signals.writing():
            st.save(state_file, acc, {**record, "spp_requested": spp})
            _write(p, opts, acc, spp, record, seconds(), timing["random"], resumed_from)
        saved.append(state_file)
        control.last_checkpoint = time.perf_counter()

    if opts.workers or opts.scheduler or opts.client is not None:
        from .cluster import render_on_cluster

        render_on_cluster(p, opts, acc, spp, seed, control, save_checkpoint, timing,
                          client=opts.client)
    else:
        while acc.done < spp and control.stop is None:
            action, last = [None], [acc.done]

            def after_pass(done: int) -> bool:  # after each draw: it may hold several passes
                action[0] = control.tick(done, done - last[0])
                last[0] = done
                return action[0] is not None

            for done, sums in r.passes(seed, acc.done, spp, carry=acc.partial, interrupt=after_pass):
                acc.add(done, sums)
            timing["random"] += r.random_seconds
            if action[0] == "checkpoint":
                save_checkpoint()
    written = []
    if control.stop == "signal":
        if opts.checkpoint is not None and acc.done > resumed_from:
            save_checkpoint()
    elif opts.checkpoint is not None:
        save_checkpoint()  # the final image, and the state that a longer render can resume
        written = list(opts.outputs)
    elif acc.done > 0:
        with signals.writing():
            written = _write(p, opts, acc, spp, record, seconds(), timing["random"], resumed_from)
    result = _result(p, acc, seconds(), timing["random"], opts.first_pass)
    farm = {k: v for k, v in timing.items() if k != "random"}
    stopped = signals.signum if control.stop == "signal" else None  # after the last pass: done
    return Outcome(result, _metadata(p, result, resumed_from), spp, stopped,
                   saved[-1] if saved else None, resumed_from, written, control.stop, farm)


def _metadata(p, result, resumed_from: int) -> dict:
    """api.metadata, with paths/s over the passes THIS run drew (a resumed render's checkpoint
    passes took no time here)."""
    meta = metadata(p, result)
    h, w, _ = result.image.shape
    meta["paths_per_second"] = w * h * (result.spp - resumed_from) / max(result.render_seconds, 1e-12)
    meta["resumed_from"] = resumed_from
    return meta


def _check_range(opts: Options, spp: int, chunk: int) -> None:
    """A pass range (--first-pass) starts on a read-back boundary and is a plain render."""
    if opts.first_pass % chunk or not 0 < opts.first_pass < spp:
        raise RangeError(f"--first-pass {opts.first_pass}: must be a multiple of {chunk} below the "
                         f"spp ({spp}), the pass the range ends before")
    if opts.resume or opts.checkpoint is not None or opts.workers or opts.scheduler:
        raise RangeError("--first-pass renders a plain range: not with --resume, --checkpoint, "
                         "--workers or --scheduler")


class RangeError(McptError, ValueError):
    pass


def _result(p, acc: Accumulator, seconds: float, random_seconds: float, first_pass: int = 0):
    return p.renderer.result(acc.totals(), acc.done - first_pass, p.scene.render.seed, seconds,
                             random_seconds)


def _write(p, opts, acc, spp, record, seconds, random_seconds, resumed_from) -> list:
    result = _result(p, acc, seconds, random_seconds, opts.first_pass)
    hdr = header(_metadata(p, result, resumed_from), record, spp, opts.first_pass)
    image, layers, extra = finish(result, opts.aovs, opts.denoise)
    hdr.update(extra)  # mcpt:aovs lists the layers written (the record, the ones computed)
    for output in opts.outputs:
        write_image(output, image, hdr, opts.exposure, layers=layers)
    return list(opts.outputs)

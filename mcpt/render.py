"""The render loop: a scene to images, the one road every render takes.

    prepare   mcpt/prepare.py             read -> build -> derive -> pack -> compile
    passes    Renderer.passes             in this process, or as Dask tasks (mcpt/farm/cluster.py),
                                          added in pass order into an Accumulator
                                          (mcpt/farm/accumulate.py); after every draw the
                                          Control (mcpt/farm/control.py) reports progress and
                                          stops (signal, --time) or checkpoints (mcpt/farm/state.py)
    write     mcpt/output/                the image and its layers (layers.py), the metadata and
                                          EXR header (metadata.py), written atomically (image.py)

``mcpt render`` (cli/render.py) calls :func:`render`; ``mcpt.api.render_scene`` is the same call
for a library user; the benchmarks call :func:`run` on a scene they prepared once. Where a render
stops, resumes or runs changes no bit (mcpt/farm/accumulate.py).

The sample count keeps one name: ``spp``, the samples per pixel asked for (the scene's
``render.spp``, which ``Options.spp`` overrides); ``Accumulator.spp`` the samples per pixel summed so
far and ``RenderResult.spp`` those in the image (fewer when a budget or a signal stopped the
render; ``spp_requested`` in the summary and the header then keeps the asked-for count).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

from .errors import McptError
from .farm import state as st
from .farm.accumulate import CHUNK, Accumulator
from .farm.control import Control
from .farm.signals import StopSignals
from .output.image import ImageError, check_output_path, write_images
from .output.layers import computed as computed_aovs
from .output.layers import finish
from .output.metadata import header, metadata
from .prepare import Prepared, prepare

log = logging.getLogger("mcpt")


class RangeError(McptError, ValueError):
    """A pass range (--first-pass) that is not one."""


class BudgetError(McptError, RuntimeError):
    """A time budget that ran out before the first draw of a render ended: no pass to write."""


@dataclass
class Options:
    outputs: list = field(default_factory=list)  # images to write (none: the result only)
    spp: int | None = None                # None: the scene's render.spp
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
    overwrite: bool = False               # replace a checkpoint already there (else refused)
    first_pass: int = 0                   # render passes first_pass .. spp-1 (a pass range)
    overrides: tuple = ()                 # -D KEY=VALUE
    workers: int | None = None
    scheduler: str | None = None
    client: object = None                 # a distributed.Client to use (tests, notebooks)
    progress: object = None               # progress(summed, spp, passes_this_run, seconds)
    chunk: int = CHUNK                    # passes per float32 read-back (mcpt/farm/accumulate.py)
    started: float = field(default_factory=time.perf_counter)


@dataclass
class Outcome:
    result: object                        # RenderResult of the passes summed
    meta: dict                            # mcpt/output/metadata.py
    spp_requested: int
    interrupted: int | None = None        # the signal number, when one stopped the render
    checkpoint: Path | None = None
    resumed_from: int = 0
    written: list = field(default_factory=list)
    stopped_by: str | None = None         # "signal", "time" or None (all passes done)
    farm: dict = field(default_factory=dict)  # cluster_seconds, workers, tasks (Dask renders)


def render(scene, opts: Options, signals: StopSignals | None = None) -> Outcome:
    """Prepare ``scene`` (a file or a Scene) as ``opts`` say, draw its passes, write
    ``opts.outputs``. Bad outputs, a missing denoiser or Dask fail here, before any work."""
    for output in opts.outputs:
        check_output_path(output)
    if opts.outputs and (opts.checkpoint is not None or opts.resume):
        st.check_state_path(st.state_path(opts.outputs[0]), resume=opts.resume,
                            overwrite=opts.overwrite)
    if opts.denoise:
        from .output.denoise import version

        version()  # no denoiser: one clear error before minutes of rendering
    if opts.workers or opts.scheduler:
        from .farm.cluster import check_workers, require_dask

        require_dask()
        if opts.workers and not opts.scheduler:
            check_workers(opts.workers)
    p = prepare(scene, spp=opts.spp, bounces=opts.bounces, seed=opts.seed,
                resolution=opts.resolution, gl_backend=opts.gl_backend,
                features_mode=opts.features_mode, clamp=opts.clamp, sampler=opts.sampler,
                aovs=computed_aovs(opts.aovs, opts.denoise), overrides=opts.overrides)
    try:
        return run(p, opts, signals)
    finally:
        p.renderer.release()


def run(p: Prepared, opts: Options, signals: StopSignals | None = None) -> Outcome:
    """The passes of a prepared scene and the images of ``opts.outputs``. ``opts.spp`` and
    ``opts.seed`` override the scene's (a benchmark renders one prepared scene many times); the
    other settings are those ``p`` was prepared with."""
    rs = p.scene.render
    if (opts.spp is not None and opts.spp != rs.spp) or (opts.seed is not None and opts.seed != rs.seed):
        p = replace(p, scene=p.scene.with_overrides(spp=opts.spp, seed=opts.seed))
    if hasattr(opts.progress, "pixels"):  # here, not in render(): a frame sequence calls run alone
        opts.progress.pixels = p.scene.camera.width * p.scene.camera.height
    loop = _Loop(p, opts, signals if signals is not None else StopSignals())
    if opts.workers or opts.scheduler or opts.client is not None:
        from .farm.cluster import render_on_cluster

        loop.farm = render_on_cluster(p, opts, loop.acc, loop.control, loop.save_checkpoint)
    else:
        loop.passes_here()
    return loop.finish()


class _Loop:
    """One run of the loop: the accumulator, the control, the checkpoints it wrote."""

    def __init__(self, p: Prepared, opts: Options, signals: StopSignals):
        self.p, self.opts, self.signals = p, opts, signals
        r = p.renderer
        self.spp, self.seed = p.scene.render.spp, p.scene.render.seed
        self.record = st.settings(p.scene, features_mode=p.features_mode, clamp=p.clamp,
                                  sampler=p.features.sampler, aovs=p.aovs,
                                  samples_per_draw=r.samples_per_draw, digest=p.scene_hash)
        self.state_file = st.state_path(opts.outputs[0]) if opts.outputs else None
        self.acc = self._start()
        self.resumed_from = self.acc.spp
        self.control = Control(opts, signals, self.spp, r.samples_per_draw, self.acc.chunk)
        self.random_seconds = 0.0
        self.farm: dict = {}
        self.saved: list = []

    def _start(self) -> Accumulator:
        r, opts = self.p.renderer, self.opts
        if (opts.checkpoint is not None or opts.resume) and self.state_file is None:
            raise ValueError("checkpoints and resume need an output (its .state.npz)")
        acc = Accumulator.empty(len(r.targets), r.height, r.width, opts.chunk)
        if opts.first_pass:
            _check_range(opts, self.spp, acc.chunk)
            acc.spp = opts.first_pass  # passes before it belong to another render of this seed
        if opts.resume:
            acc = st.resume(self.state_file, self.record, len(r.targets), self.spp,
                            r.samples_per_draw, opts.chunk)
        return acc

    def passes_here(self) -> None:
        """Draw the passes in this process, pausing for checkpoints, until done or stopped."""
        r, acc, control = self.p.renderer, self.acc, self.control
        while acc.spp < self.spp and control.stop is None:
            action, last = [None], [acc.spp]

            def after_draw(summed: int, action=action, last=last) -> bool:  # a draw: several passes
                action[0] = control.tick(summed, summed - last[0])
                last[0] = summed
                return action[0] is not None

            control.draw_started = time.perf_counter()  # not the checkpoint written before
            for summed, sums in r.passes(self.seed, acc.spp, self.spp, chunk=acc.chunk,
                                         carry=acc.partial, interrupt=after_draw,
                                         drop_draw=control.drop_draw):
                acc.add(summed, sums)
            self.random_seconds += r.random_seconds
            if action[0] == "checkpoint":
                self.save_checkpoint()

    def save_checkpoint(self, final: bool = False) -> None:
        """The state file and the images. A state or (before the end) an image that cannot be
        written is a warning and the render goes on (issue #24: a full disk used to end hours of
        passes with nothing written); the final images fail as any render's would. A finished
        render writes its images first (issue #24 item 5: on a nearly full disk the last state
        file took the room of the final image, left at an earlier checkpoint's passes)."""
        self.control.last_checkpoint = time.perf_counter()
        if final and self.acc.spp >= self.spp:
            self._write_final()
            self._save_state()
            return
        self._save_state()
        try:
            with self.signals.writing():
                self._write()
        except (OSError, ImageError) as exc:
            if final:
                raise
            log.warning("checkpoint images not written (%s); the render goes on",
                        " ".join(str(exc).split()))

    def _save_state(self) -> None:
        try:
            with self.signals.writing():
                st.save(self.state_file, self.acc, {**self.record, "spp_requested": self.spp})
            self.saved.append(self.state_file)
        except OSError as exc:
            log.warning("checkpoint %s not written (%s); the render goes on", self.state_file,
                        exc.strerror or exc)

    def _write_final(self) -> None:
        """The images of a finished render. Where they cannot be written beside the state of an
        earlier checkpoint (a full disk, most likely), that state (fewer passes than the image
        holds) makes room, and they are written once more; a second failure is the render's."""
        try:
            with self.signals.writing():
                self._write()
            return
        except (OSError, ImageError) as exc:
            if not self.state_file.is_file():
                raise
            log.warning("final image not written (%s); removing the earlier checkpoint %s to make "
                        "room for it", " ".join(str(exc).split()), self.state_file)
        self.state_file.unlink()
        with self.signals.writing():
            self._write()

    def finish(self) -> Outcome:
        """The last checkpoint or image, and what the render did."""
        opts, stop = self.opts, self.control.stop
        written = []
        if stop == "time" and self.acc.spp == opts.first_pass:  # issue #24 item 8: a draw cut
            c = self.control
            raise BudgetError(f"--time {opts.time_budget:g}: the first draw would end at about "
                              f"{c.foreseen_end:.1f} s (set-up took {c.t_run - opts.started:.2f} s), "
                              "past the budget; nothing written, give it more time")
        if stop == "signal":
            if opts.checkpoint is not None and self.acc.spp > self.resumed_from:
                self.save_checkpoint(final=True)
        elif opts.checkpoint is not None:
            self.save_checkpoint(final=True)  # the final image, and the state that a longer render can resume
            written = list(opts.outputs)
        elif self.acc.spp > 0 and opts.outputs:
            with self.signals.writing():
                written = self._write()
        result = self._result()
        stopped = self.signals.signum if stop == "signal" else None  # after the last pass: done
        return Outcome(result, metadata(self.p, result, self.resumed_from), self.spp, stopped,
                       self.saved[-1] if self.saved else None, self.resumed_from, written, stop,
                       self.farm)

    def _result(self):
        return self.p.renderer.result(self.acc.totals(), self.acc.spp - self.opts.first_pass,
                                      self.seed, self.control.seconds(), self.random_seconds)

    def _write(self) -> list:
        result = self._result()
        hdr = header(metadata(self.p, result, self.resumed_from), self.record, self.spp,
                     self.opts.first_pass)
        image, layers, extra = finish(result, self.opts.aovs, self.opts.denoise)
        hdr.update(extra)  # mcpt:aovs lists the layers written (the record, the ones computed)
        return write_images(self.opts.outputs, image, hdr, self.opts.exposure, layers,
                            alpha=result.alpha)


def _check_range(opts: Options, spp: int, chunk: int) -> None:
    """A pass range (--first-pass) starts on a read-back boundary and is a plain render."""
    if opts.first_pass % chunk or not 0 < opts.first_pass < spp:
        raise RangeError(f"--first-pass {opts.first_pass}: must be a multiple of {chunk} below the "
                         f"spp ({spp}), the pass the range ends before")
    if opts.resume or opts.checkpoint is not None or opts.workers or opts.scheduler:
        raise RangeError("--first-pass renders a plain range: not with --resume, --checkpoint, "
                         "--workers or --scheduler")

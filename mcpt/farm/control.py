"""Asked by the render loop (mcpt/render.py) after every draw: report progress, and stop (a signal,
the time budget) or pause for a checkpoint."""

from __future__ import annotations

import logging
import time

from .signals import StopSignals

log = logging.getLogger("mcpt")

#: A render projected to take longer than this (seconds) is announced with a warning.
LONG_RENDER_SECONDS = 3600.0


class Control:
    """``opts``: the loop's Options (progress, time_budget, started, checkpoint); ``spp``: the
    samples per pixel asked for; ``samples_per_draw`` and ``chunk``: the draw grid
    (mcpt/gpu/render.py), which decides where the next draw ends."""

    def __init__(self, opts, signals: StopSignals, spp: int, samples_per_draw: int = 1,
                 chunk: int = 64):
        self.opts, self.signals, self.spp = opts, signals, spp
        self.samples_per_draw, self.chunk = samples_per_draw, chunk
        self.t_run = time.perf_counter()
        self.last_checkpoint = self.t_run
        self.passes_run = 0
        self.stop: str | None = None
        self.draw_started = self.t_run  # when the draw in progress began (drop_draw)
        self._first_band = (None, 0.0, 0.0)  # (draw_started, time, done) after its first band
        self.foreseen_end = 0.0  # seconds from the start at which drop_draw saw the draw end

    def tick(self, summed: int, drawn: int = 1) -> str | None:
        """``summed`` samples per pixel of the render exist, ``drawn`` of them drawn since the
        last tick; returns 'stop', 'checkpoint' or None."""
        first = self.passes_run == 0
        self.passes_run += drawn
        now = time.perf_counter()
        if first:
            self._warn_if_long(summed, now)
        if self.opts.progress is not None:
            self.opts.progress(summed, self.spp, self.passes_run, now - self.t_run)
        per_pass = (now - self.t_run) / max(self.passes_run, 1)
        if self.signals.stopped:
            self.stop = "signal"
        elif (self.opts.time_budget is not None and summed < self.spp
              and now - self.opts.started + per_pass * self.next_draw(summed) > self.opts.time_budget):
            # Stop before the draw that would end past the budget: ends within one draw of it.
            self.stop = "time"
        self.draw_started = now
        if self.stop:
            return "stop"
        if self.opts.checkpoint is not None and now - self.last_checkpoint >= self.opts.checkpoint:
            return "checkpoint"
        return None

    def drop_draw(self, summed: int, done: float) -> bool:
        """Asked between the bands of a draw (mcpt/gpu/bands.py), ``done`` the share of it
        drawn: whether to drop it and stop at ``summed``, the passes before it. On a signal
        (issue #24 item 8: a signal used to wait for the whole draw, up to 2^22 paths), or when
        the draw would end later than half the overrun the time budget allows (the other half
        is left for writing): a draw longer than foreseen (the machine got busier; the first
        draw of a render) is cut instead of running seconds past the budget. The draw's end is
        foreseen from its bands after the first (which may hold the driver's shader compile)."""
        if self.signals.stopped:
            self.stop = "signal"
            return True
        budget = self.opts.time_budget
        if budget is None:
            return False
        now = time.perf_counter()
        if self._first_band[0] != self.draw_started:  # the first band of this draw
            self._first_band = (self.draw_started, now, done)
        _, t1, d1 = self._first_band
        end = now + (now - t1) * (1.0 - done) / (done - d1) if done > d1 else now
        self.foreseen_end = end - self.opts.started
        if self.foreseen_end > budget + overrun(budget) / 2:
            self.stop = "time"
            return True
        return False

    def next_draw(self, summed: int) -> int:
        """Passes the draw after pass ``summed`` holds (mcpt/gpu/render.py: on the global grid)."""
        spd, chunk = self.samples_per_draw, self.chunk
        return max(1, min(spd - summed % spd, chunk - summed % chunk, self.spp - summed))

    def seconds(self) -> float:
        """Wall time since the loop started drawing (set-up excluded)."""
        return time.perf_counter() - self.t_run

    def _warn_if_long(self, summed: int, now: float) -> None:
        """After the first draw: say so when the whole render would take longer than an hour at
        the speed measured here (issue #10: 2^40 spp used to run until killed, silently)."""
        per_pass = (now - self.t_run) / max(self.passes_run, 1)
        left = per_pass * (self.spp - summed)
        if left > LONG_RENDER_SECONDS and self.opts.time_budget is None:
            log.warning("%d spp will take about %s at %.3g s a pass measured here; --time SECONDS "
                        "bounds it, --checkpoint SECONDS keeps what is done", self.spp,
                        _duration(left), per_pass)


def overrun(budget: float) -> float:
    """Seconds a render with ``--time budget`` may end after it, writing included (issue #24
    item 8: by T + 10 % or T + 1 s, whichever is larger)."""
    return max(0.1 * budget, 1.0)


def _duration(seconds: float) -> str:
    for unit, size in (("years", 365.25 * 86400), ("days", 86400), ("hours", 3600)):
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds / 60:.3g} minutes"

"""Progress of ``mcpt render`` on stderr: a bar on a terminal, or plain lines for farm managers.

``plain`` prints one line every ``interval`` seconds (and one at the end) in a fixed format that a
regular expression can read (numbers only, fixed keys, one space apart)::

    mcpt: progress 42.2% passes 27/64 paths/s 1.234e+05 left 12.3s

The interval is 5 s, or ``$MCPT_PROGRESS_INTERVAL`` seconds (a number >= 0; anything else is
refused in one line, exit 2). ``left`` is ``-`` until a pass has
been timed. The paths/s figure counts the passes drawn by this run (a resumed render does not
count the checkpoint's passes as fast ones).
"""

from __future__ import annotations

import math
import os
import sys
import time

from mcpt.errors import McptError

PLAIN_REGEX = (r"^mcpt: progress (?P<percent>\d+\.\d)% passes (?P<done>\d+)/(?P<total>\d+) "
               r"paths/s (?P<rate>\S+) left (?P<left>\S+)$")


class Bar:
    """Passes done, paths/s and time left, redrawn in place on a terminal."""

    def __init__(self, pixels: int = 1):
        self.pixels = pixels
        self.open = False

    def __call__(self, done: int, total: int, run: int, seconds: float) -> None:
        self.open = done != total
        rate = self.pixels * run / max(seconds, 1e-9)
        left = seconds / max(run, 1) * (total - done)
        bar = "#" * int(30 * done / total)
        sys.stderr.write(f"\r[{bar:<30}] {done}/{total} passes  {rate / 1e6:6.2f} Mpaths/s  "
                         f"{left:6.1f} s left ")
        if done == total:
            sys.stderr.write("\n")
        sys.stderr.flush()

    def close(self) -> None:
        if self.open:  # stopped early: end the line the bar was redrawn on
            sys.stderr.write("\n")
            self.open = False


class Plain:
    """One line every ``interval`` seconds; see the module docstring for the format."""

    def __init__(self, pixels: int = 1, interval: float = 5.0, stream=None):
        self.pixels, self.interval = pixels, interval
        self.stream = stream
        self.last = None
        self.pending = None

    def __call__(self, done: int, total: int, run: int, seconds: float) -> None:
        self.pending = (done, total, run, seconds)
        now = time.monotonic()
        if self.last is None:
            self.last = now
        elif now - self.last >= self.interval or done == total:
            self.last = now
            self._line(*self.pending)
            self.pending = None

    def close(self) -> None:
        """The last state, if it has not been printed (a render that stopped early)."""
        if self.pending is not None:
            self._line(*self.pending)
            self.pending = None

    def _line(self, done, total, run, seconds) -> None:
        rate = self.pixels * run / max(seconds, 1e-9)
        left = f"{seconds / run * (total - done):.1f}s" if run else "-"
        stream = self.stream or sys.stderr
        stream.write(f"mcpt: progress {100.0 * done / total:.1f}% passes {done}/{total} "
                     f"paths/s {rate:.3e} left {left}\n")
        stream.flush()


def make(mode: str, quiet: bool, interval: float | None = None):
    """``auto``: the bar on a terminal, plain lines when stdout is not one; ``none`` or --quiet: off.
    The plain interval: ``interval``, else $MCPT_PROGRESS_INTERVAL, else 5 seconds."""
    if quiet or mode == "none":
        return None
    if mode == "auto":
        mode = "bar" if sys.stdout.isatty() and sys.stderr.isatty() else "plain"
    if mode == "bar":
        return Bar()
    return Plain(interval=_env_interval() if interval is None else interval)


def _env_interval() -> float:
    """$MCPT_PROGRESS_INTERVAL (seconds, finite, >= 0), else 5. A bad value is bad input: one
    line, exit 2, before any work (issue #24 item 17: 'abc' was an internal error after set-up)."""
    text = os.environ.get("MCPT_PROGRESS_INTERVAL", "").strip()
    if not text:
        return 5.0
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise McptError(f"MCPT_PROGRESS_INTERVAL={text[:40]!r}: expected a number of seconds >= 0 "
                        "(default 5)")
    return value

"""SIGINT, SIGTERM and SIGHUP as a request to stop at the next pass boundary.

Farm schedulers stop jobs with SIGTERM (then SIGKILL after a grace period), terminals send SIGHUP
when they close, users press Ctrl-C. While passes are drawn, the first signal only sets a flag: the
pass loop sees it after the current pass, the render writes a checkpoint if one was asked for, and
the command exits with 128 + the signal number (130, 143, 129), the shell's convention. While an
image or checkpoint is being written, a signal raises :class:`Interrupted` at once: the writers
(mcpt/output/image.py, state.py) remove their temporary file on any exception, so the file already
at the path stays as it was. A second signal also raises at once (a user who presses Ctrl-C twice
does not want to wait for a pass).
"""

from __future__ import annotations

import contextlib
import signal
import threading

SIGNALS = tuple(s for s in (signal.SIGINT, signal.SIGTERM, getattr(signal, "SIGHUP", None)) if s)


class Interrupted(BaseException):
    """Raised by a signal that cannot wait for a pass boundary (BaseException: no ``except
    Exception`` on the way swallows it)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum

    @property
    def exit_code(self) -> int:
        return 128 + self.signum

    @property
    def name(self) -> str:
        return signal.Signals(self.signum).name


class StopSignals:
    """Context manager that turns the stop signals into :attr:`signum` (None until one came).

    Outside the main thread (a Dask worker, a test's thread) signals cannot be caught: it then
    does nothing and :attr:`signum` stays None.
    """

    def __init__(self):
        self.signum: int | None = None
        self._writing = False
        self._old: dict = {}

    def __enter__(self) -> StopSignals:
        if threading.current_thread() is threading.main_thread():
            for s in SIGNALS:
                # A signal the parent chose to ignore (nohup: SIGHUP; a background job: SIGINT)
                # stays ignored (issue #24): the user asked for the render to outlive it.
                if signal.getsignal(s) is not signal.SIG_IGN:
                    self._old[s] = signal.signal(s, self._handle)
        return self

    def __exit__(self, *exc) -> None:
        for s, old in self._old.items():
            signal.signal(s, old)
        self._old.clear()

    def _handle(self, signum, frame) -> None:
        first = self.signum is None
        if first:
            self.signum = signum
        if self._writing or not first:
            raise Interrupted(self.signum)

    @property
    def stopped(self) -> bool:
        return self.signum is not None

    @contextlib.contextmanager
    def writing(self):
        """A block during which a signal interrupts at once (writing files)."""
        self._writing = True
        try:
            yield
        finally:
            self._writing = False

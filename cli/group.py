"""The click group and the error boundary shared by every command (commands: cli/main.py)."""

from __future__ import annotations

import functools
import logging
import os
import sys

import click

from mcpt import __version__
from mcpt.errors import McptError
from mcpt.farm.signals import Interrupted
from mcpt.gpu.context import GLError

EXIT_INTERNAL, EXIT_INPUT, EXIT_GL = 1, 2, 3


def _command_name() -> str:
    ctx = click.get_current_context(silent=True)
    return ctx.info_name if ctx is not None and ctx.parent is not None else "COMMAND"


def _verbosity() -> int:
    ctx = click.get_current_context(silent=True)
    return int(ctx.find_root().params.get("verbose") or 0) if ctx else 0


def reports_errors(fn):
    """Turn user errors (:class:`mcpt.errors.McptError`) into one 'mcpt: error: ...' line, exit 2.

    Exit codes (README "Exit codes"): 0 done; 1 internal error (a bug, reported on one line unless
    -vv asks for the traceback); 2 bad input; 3 no usable OpenGL; 128 + the signal for a stop
    signal (130 SIGINT, 143 SIGTERM, 129 SIGHUP: mcpt/farm/signals.py); 141 stdout closed by its
    reader (stdout_closed). No command writes its image
    before the work is done, and images are renamed into place when complete
    (mcpt/output/image.py), so no failure leaves a partial image. Click's own usage errors (a bad
    option value found by a command) keep click's message and its exit status, 2."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except click.ClickException:
            raise
        except BrokenPipeError:
            stdout_closed()
        except GLError as exc:
            click.echo(f"mcpt: error: {exc}", err=True)
            sys.exit(EXIT_GL)
        except McptError as exc:
            click.echo(f"mcpt: error: {exc}", err=True)
            sys.exit(EXIT_INPUT)
        except Interrupted as exc:  # a signal during a write: the write was undone
            click.echo(f"mcpt: interrupted by {exc.name}{_which(exc)}", err=True)
            sys.exit(exc.exit_code)
        except KeyboardInterrupt:
            click.echo("mcpt: interrupted", err=True)
            sys.exit(130)
        except Exception as exc:  # noqa: BLE001 - the error boundary of the CLI
            if _verbosity() >= 2:
                raise
            msg = " ".join(str(exc).split())
            click.echo(f"mcpt: internal error: {type(exc).__name__}: {msg} (run 'mcpt -vv "
                       f"{_command_name()} ...' for the traceback)", err=True)
            sys.exit(1)

    return wrapper


def _which(exc: Interrupted) -> str:
    """Which outputs hold the new image and which were left as they were (output/image.py
    write_images records them; issue #24)."""
    kept, written = getattr(exc, "kept", None), getattr(exc, "written", [])
    if kept is None:
        return ": every output left as it was"
    new = f"; {', '.join(written)} written" if written else ""
    return f" while writing: {', '.join(kept)} left as it was{new}"


EXIT_SIGPIPE = 128 + 13  # what a shell reports for a command killed by SIGPIPE


def stdout_closed() -> None:
    """The reader of stdout went away (``mcpt info scene.yaml | head``): stop quietly, as a
    command killed by SIGPIPE does, exit 141 (issue #24 item 17: a BrokenPipeError was an
    internal error, exit 1). stdout is pointed at /dev/null first, so the interpreter's last
    flush at exit cannot fail again (Python's documented recipe, library/signal.html)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # no real stdout (click's test runner): nothing to flush
        pass
    sys.exit(EXIT_SIGPIPE)


class _OneLineUsageError(click.UsageError):
    """click's usage errors print a usage block; mcpt prints one line naming the option."""

    def show(self, file=None) -> None:
        hint = f" (see '{self.ctx.command_path} --help')" if self.ctx is not None else ""
        click.echo(f"mcpt: error: {self.format_message()}{hint}", file=file, err=True)


class _NoCommand(click.UsageError):
    """``mcpt`` alone: the help, then the error on a line of its own (issue #24 item 19: the hint
    was glued to the help's last line)."""

    def show(self, file=None) -> None:
        click.echo(self.ctx.get_help(), file=file, err=True)
        click.echo("mcpt: error: missing COMMAND (see 'mcpt --help')", file=file, err=True)


class _Group(click.Group):
    """One-line usage errors; a closed stdout (--help, --version into `head`) stops quietly."""

    def parse_args(self, ctx, args):
        try:
            return super().parse_args(ctx, args)
        except click.exceptions.NoArgsIsHelpError as exc:
            raise _NoCommand(exc.message, exc.ctx) from None
        except click.UsageError as exc:
            raise _OneLineUsageError(exc.message, exc.ctx) from None
        except BrokenPipeError:
            stdout_closed()

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except click.UsageError as exc:  # a subcommand's bad option or argument
            raise _OneLineUsageError(exc.format_message(), exc.ctx) from None
        except BrokenPipeError:
            stdout_closed()


class _ClickLogHandler(logging.Handler):
    """Log records as 'mcpt: warning: ...' lines on the CURRENT stderr (click's), so they reach
    the terminal and click's test runner alike (logging.basicConfig keeps the first stream)."""

    def emit(self, record: logging.LogRecord) -> None:
        try:
            click.echo(f"mcpt: {record.levelname.lower()}: {record.getMessage()}", err=True)
        except Exception:  # pragma: no cover - logging must never raise
            self.handleError(record)


def _configure_logging(verbose: int) -> None:
    log = logging.getLogger("mcpt")
    if not any(isinstance(h, _ClickLogHandler) for h in log.handlers):
        log.addHandler(_ClickLogHandler())
    log.setLevel(logging.WARNING if verbose == 0 else logging.INFO if verbose == 1 else logging.DEBUG)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="mcpt")
@click.option("-v", "--verbose", count=True, help="More log output (-v info, -vv debug).")
def main(verbose: int) -> None:
    """mcpt: a Monte Carlo path tracer on headless OpenGL."""
    _configure_logging(verbose)

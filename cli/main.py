"""``mcpt`` entry point: the click group and the error boundary shared by every command."""

from __future__ import annotations

import functools
import logging
import sys

import click

from mcpt import __version__


def user_errors():
    """Exception types whose message is meant for the user: printed as one line, exit status 2."""
    from mcpt.context import GLError
    from mcpt.image import ImageError
    from mcpt.loader import LoadError
    from mcpt.mesh import MeshError
    from mcpt.render import RenderError
    from mcpt.scene import SceneError
    from mcpt.shader import ShaderError
    from mcpt.tbo import TBOError

    return (GLError, ImageError, LoadError, MeshError, RenderError, SceneError, ShaderError, TBOError)


def reports_errors(fn):
    """Turn library errors into one 'mcpt: error: ...' line and a non-zero exit."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except user_errors() as exc:
            click.echo(f"mcpt: error: {exc}", err=True)
            sys.exit(2)

    return wrapper


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="mcpt")
@click.option("-v", "--verbose", count=True, help="More log output (-v info, -vv debug).")
def main(verbose: int) -> None:
    """mcpt: a Monte Carlo path tracer on headless OpenGL."""
    level = logging.WARNING if verbose == 0 else logging.INFO if verbose == 1 else logging.DEBUG
    logging.basicConfig(level=level, format="mcpt: %(levelname)s: %(message)s")


def _register() -> None:
    from . import info, render  # noqa: F401  (each module adds its command to `main`)
    from . import bench  # noqa: F401  (mcpt bench: bench/ sweeps, issue #5)


_register()

"""``mcpt`` entry point: the click group with every command registered.

Each command lives in its own module and registers itself on the group of cli/group.py when
imported; this module only imports them, so no command module imports another.
"""

from __future__ import annotations

from . import bench, convert, encode, info, merge, render  # noqa: F401  (each adds its command to `main`)
from .group import main

__all__ = ["main"]

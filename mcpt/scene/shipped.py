"""The scenes shipped with mcpt (the source tree's scenes/ folder, installed as ``mcpt.scenes``)."""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def shipped_dir() -> Path:
    """The folder of the shipped scenes: scenes/ in a checkout, mcpt/scenes in a wheel."""
    return Path(str(resources.files("mcpt.scenes")))


def shipped(name: str) -> Path:
    """A shipped scene file by name, e.g. ``shipped("cornell-box.yaml")``."""
    return shipped_dir() / name

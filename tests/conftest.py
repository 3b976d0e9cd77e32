import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared"


@pytest.fixture(scope="session")
def gl():
    """The GL context of the back end under test (MCPT_GL_BACKEND: egl, osmesa; default auto)."""
    from mcpt.context import shared_context

    return shared_context(os.environ.get("MCPT_GL_BACKEND"))


def shared_path(*parts) -> Path:
    p = SHARED.joinpath(*parts)
    if not p.exists():
        pytest.skip(f"shared material missing: {p}")
    return p

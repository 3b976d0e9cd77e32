"""Denoising with Intel Open Image Denoise (the optional ``mcpt[denoise]`` extra: the ``pyoidn`` wheel,
which bundles OIDN and its CPU device).

OIDN's ``RT`` filter takes the noisy beauty plus the albedo and normal AOVs of the first
non-specular vertex (which it recommends over the first hit: a mirror then shows what it
reflects), in HDR mode for linear radiance. The result is biased (a learned filter), so mcpt
keeps the raw beauty beside it (``raw.R/G/B`` in the EXR) and says so in the header.
"""

from __future__ import annotations

import numpy as np

from ..errors import McptError


class DenoiseError(McptError):
    """Denoising was asked for but cannot be done (the extra is not installed, OIDN failed)."""


def available() -> bool:
    try:
        import pyoidn  # noqa: F401
    except ImportError:
        return False
    return True


def denoise(color: np.ndarray, albedo: np.ndarray | None = None,
            normal: np.ndarray | None = None) -> np.ndarray:
    """(H, W, 3) float32 linear radiance -> denoised (H, W, 3) float32, row 0 at the top.

    ``albedo`` in [0, 1] and ``normal`` (unit, world space) are the AOVs of the same render;
    OIDN prefilters them itself (they are Monte Carlo estimates too, so clean_aux stays off).
    """
    try:
        import pyoidn
    except ImportError:
        raise DenoiseError("--denoise needs Intel Open Image Denoise: pip install 'mcpt[denoise]'") from None
    prep = lambda a: None if a is None else np.ascontiguousarray(a, np.float32)  # noqa: E731
    try:
        out = pyoidn.denoise(prep(np.maximum(color, 0.0)), prep(albedo),
                             prep(None if normal is None else np.clip(normal, -1.0, 1.0)),
                             hdr=True, quality="high")
    except (RuntimeError, ValueError, TypeError) as exc:
        raise DenoiseError(f"denoising failed: {' '.join(str(exc).split())}") from None
    return np.asarray(out, np.float32)


def version() -> str:
    """``"oidn 2.5.1"``: what the EXR header names as the denoiser (DenoiseError without the extra)."""
    try:
        from pyoidn.version import oidn_version
    except ImportError:
        raise DenoiseError("--denoise needs Intel Open Image Denoise: pip install 'mcpt[denoise]'") from None
    return f"oidn {oidn_version}"

"""Camera rays on the host: the reference the tests hold the shader's glsl/camera.glsl against."""

from __future__ import annotations

import numpy as np

from mcpt.shading.camera import basis


def primary_rays(position, look_at, up, vfov_deg, width, height, jitter=(0.5, 0.5)):
    """Origins (camera-relative: zeros) and unit directions of every pixel, rows from the top;
    ``jitter``: the sample's offset inside its pixel, in pixels (0.5: the centre)."""
    f, r, u = basis(position, look_at, up, vfov_deg, width, height)
    i, j = np.meshgrid(np.arange(width), np.arange(height))
    x = 2.0 * (i + jitter[0]) / width - 1.0
    y = 1.0 - 2.0 * (j + jitter[1]) / height
    d = f + x[..., None] * r + y[..., None] * u
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return np.zeros_like(d), d

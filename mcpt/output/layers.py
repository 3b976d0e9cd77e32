"""From a render's result to what is written: the image, its extra EXR layers and header keys.

``--aov`` names add ``layer.channel`` channels (mcpt/gpu/aov.py). ``--denoise`` runs OIDN on the
beauty with the albedo and normal AOVs (mcpt/output/denoise.py): the image written (EXR RGB and
PNG) is then the denoised one, the raw beauty is kept as ``raw.R/G/B``, and the header says
``mcpt:denoised = oidn X.Y.Z, biased`` (a learned filter has no unbiasedness to offer).
"""

from __future__ import annotations

import time

import numpy as np

from ..gpu import aov as aov_mod


def computed(aovs, denoise: bool) -> tuple[str, ...]:
    """The AOVs a render must compute: those asked for plus, for --denoise, albedo and normal."""
    names = set(aovs) | (set(aov_mod.DENOISE_AOVS) if denoise else set())
    return tuple(n for n in aov_mod.AOVS if n in names)


def feature_flags(aovs, denoise: bool) -> dict:
    """Features the renderer needs for them (the AOV targets; the squares target for variance)."""
    names = computed(aovs, denoise)
    flags = {}
    if aov_mod.needs_targets(names):
        flags["aov"] = True
    if "variance" in names:
        flags["variance"] = True
    return flags


def finish(result, aovs=(), denoise: bool = False) -> tuple[np.ndarray, dict, dict]:
    """(image, layers, header keys) for ``result`` (mcpt.gpu.render.RenderResult)."""
    values = dict(result.aovs)
    if result.variance is not None:
        values["variance"] = result.variance
    layers = aov_mod.layers(values, aovs)
    header = {"mcpt:aovs": ",".join(aovs)} if aovs else {}
    image = result.image
    if denoise:
        from .denoise import denoise as oidn
        from .denoise import version

        name = version()
        t0 = time.perf_counter()
        image = oidn(result.image, values["albedo"], values["normal"])
        header["mcpt:denoised"] = f"{name}, biased"
        header["mcpt:denoise_seconds"] = time.perf_counter() - t0
        layers = {"raw": (result.image, "RGB"), **layers}
    return image, layers, header

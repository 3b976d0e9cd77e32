"""What a render says about itself: the summary of ``mcpt render --json`` and the EXR header.

Built here only, from the prepared scene (mcpt/prepare.py) and the result of the passes
(mcpt/gpu/render.py RenderResult); the render loop (mcpt/render.py) writes both. ``mcpt merge``
(mcpt/farm/merge.py) and ``--resume`` compare the ``mcpt:*`` keys of the record (mcpt/farm/state.py
settings) that the header carries.
"""

from __future__ import annotations

from .. import __version__
from ..scene.frame import frame_metadata


def metadata(p, result, resumed_from: int = 0) -> dict:
    """The render's summary; ``paths_per_second`` counts the passes THIS run drew (a resumed
    render's checkpoint passes took no time here)."""
    cam = p.scene.camera
    h, w, _ = result.image.shape
    return {
        "scene": str(p.scene.source_path) if p.scene.source_path else (p.scene.name or ""),
        "width": cam.width, "height": cam.height, "spp": result.spp, "bounces": result.bounces,
        "seed": result.seed, "render_seconds": result.render_seconds,
        "random_seconds": result.random_seconds, "setup_seconds": p.setup_seconds,
        "paths_per_second": w * h * (result.spp - resumed_from) / max(result.render_seconds, 1e-12),
        "dropped_samples": result.dropped_samples,
        "gl_backend": p.gl.backend, "gl_renderer": p.gl.renderer, "gl_version": p.gl.version,
        "features": dict(p.features.defines()),
        "triangles": p.world.n_triangles, "mcpt_version": __version__,
        **result.setup,
        "resumed_from": resumed_from,
        **frame_metadata(p.scene),  # issue #26: a frame of a sequence says which
    }


def header(meta: dict, record: dict, spp_requested: int, first_pass: int = 0) -> dict:
    """EXR header keys: the metadata plus the record ``mcpt merge`` and resume compare, each as
    ``mcpt:KEY`` (nested dicts as their repr). ``mcpt:spp`` is the passes the image holds,
    ``mcpt:first_pass`` the first of them."""
    keys = {**meta, **record, "spp_requested": spp_requested, "first_pass": first_pass}
    return {f"mcpt:{k}": (v if not isinstance(v, dict) else repr(v)) for k, v in keys.items()}

"""Options shared by commands that render."""

from __future__ import annotations

import math
import os
import re

import click

from mcpt.gpu.context import BACKENDS
from mcpt.gpu.features import SAMPLERS


def parse_resolution(ctx, param, value):
    if value is None:
        return None
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", value)
    if not m:
        raise click.BadParameter(f"{value!r} is not WIDTHxHEIGHT (e.g. 256x256)")
    return int(m.group(1)), int(m.group(2))


def finite(ctx, param, value):
    """A float option that must be a finite number (click's float accepts 'nan' and 'inf')."""
    if value is not None and not math.isfinite(value):
        raise click.BadParameter(f"{value} is not a finite number")
    return value


def positive_finite(ctx, param, value):
    """A finite float option > 0 (e.g. --clamp: 0 or less would zero or negate radiance)."""
    value = finite(ctx, param, value)
    if value is not None and not value > 0:
        raise click.BadParameter(f"{value} must be greater than 0")
    return value


def no_cache(ctx, param, value):
    """--no-cache: the set-up cache (mcpt/cache.py) is neither read nor written, in this process
    and the farm workers it starts (they inherit MCPT_CACHE)."""
    if value:
        os.environ["MCPT_CACHE"] = "0"
    return value


def render_options(fn):
    for opt in reversed([
        click.option("--spp", type=int, help="Samples per pixel (overrides the scene)."),
        click.option("--bounces", type=int, help="Max scattering events: 0 emitters only, 1 direct light."),
        click.option("--seed", type=int, help="Seed of every random number (same seed, same image)."),
        click.option("--resolution", callback=parse_resolution, metavar="WxH",
                     help="Image size in pixels, e.g. 512x512."),
        click.option("--gl-backend", type=click.Choice(BACKENDS), default=None,
                     help="OpenGL back end (default: $MCPT_GL_BACKEND or auto = EGL, then OSMesa)."),
        click.option("--features", "features_mode", type=click.Choice(["scene", "all"]), default="scene",
                     show_default=True,
                     help="'scene': compile only what the scene uses; 'all': the full uber-shader."),
        click.option("--sampler", type=click.Choice(SAMPLERS), default=SAMPLERS[0], show_default=True,
                     help="Random numbers: 'sobol' padded Owen-scrambled Sobol' (converges faster, "
                          "computed on the GPU); 'independent' uniform numbers uploaded every pass."),
        click.option("--no-cache", is_flag=True, expose_value=False, callback=no_cache,
                     help="Build the scene afresh: neither read nor write the set-up cache "
                          "($MCPT_CACHE_DIR, else ~/.cache/mcpt; MCPT_CACHE=0 does the same)."),
    ]):
        fn = opt(fn)
    return fn


def check_farm(workers, scheduler) -> None:
    """--workers / --scheduler before any work (issue #24 items 17, 19): both at once is refused
    (a LocalCluster of N, or an existing cluster: the scheduler won, --workers was ignored without
    a word); the scheduler's address is checked and probed (mcpt/farm/cluster.py check_scheduler:
    empty, not tcp://, a bad port, refused, unknown host, one line each)."""
    if workers is not None and scheduler is not None:
        raise click.UsageError(f"--workers {workers} starts a local cluster and --scheduler uses an "
                               "existing one: give one of them")
    if scheduler is not None:
        from mcpt.farm.cluster import check_scheduler, require_dask

        require_dask()
        check_scheduler(scheduler)

"""The packed buffers of a cached world, kept in the set-up cache too (mcpt/cache.py, issue #23):
packing 10^6 triangles (the traversal's node and triangle records, mcpt/shapes/bvh.py gpu_nodes)
costs more than reading the world back, so a warm set-up reads the buffers instead.

The key builds on the world's (mcpt/shapes/world_cache.py: every file and input the world depends
on) and adds what packing reads besides the world: the features (what is packed, in which
layout), the camera (the uniforms) and the source of the packing code. A world that did not go
through the cache (``--no-cache``, an uncacheable scene) is packed afresh.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from .. import cache
from ..shapes import world_cache

log = logging.getLogger("mcpt")

#: mcpt/ subfolders whose source shapes the packed buffers.
_PACK_SOURCES = ("gpu", "shading", "shapes")


def cached_pack(world, features, pack: Callable, enabled: bool | None = None):
    """``pack(world, features)`` (mcpt.gpu.pack.pack), read from the cache where it was kept."""
    world_key = getattr(world, "cache_key", None)
    if world_key is None or not cache.enabled(enabled):
        return pack(world, features)
    key = cache.key_of("packed", world_key, features.key, world.scene.camera.model_dump(mode="json"),
                       world_cache.versions(_PACK_SOURCES))
    store = cache.Store("packed")
    hit = store.get(key)
    if hit is not None:
        meta, arrays = hit
        try:
            return world_cache.decode(meta["packed"], arrays)
        except Exception as exc:  # noqa: BLE001 -- an entry that does not decode is a miss
            log.info("cache: packed entry unusable (%s: %s)", type(exc).__name__, exc)
    packed = pack(world, features)
    arrays: dict = {}
    try:
        meta = {"packed": world_cache.encode(packed, arrays)}
    except world_cache.Uncacheable as exc:
        log.info("cache: packed buffers not cached (%s)", exc)
        return packed
    store.put_behind(key, meta, arrays)
    return packed

"""The built world, kept in the content-addressed cache (mcpt/cache.py): a second render, a resume or
a farm worker of the same scene skips reading the meshes, the duplicate search and the BVH build
(issue #23: 10^6 triangles take seconds to build, a fraction of a second to read back).

The key hashes everything :func:`mcpt.shapes.world.load_world` reads and every input that shapes
what it returns: the scene as validated, without what the world does not depend on (the render
settings, the camera's aim and image: only its position, the rebasing origin, is used); the bytes
of every file the scene names by path (meshes, textures, environment maps) and of the files a mesh
names (an OBJ's MTL files, a .gltf's buffers and images); the source of the Python modules that
build worlds and the versions of numpy and Assimp. Files found only while loading (textures an
MTL file names) are recorded in the entry with their hashes and checked on every hit. A scene
that reads a mesh format whose companions mcpt cannot name is not cached.

An entry stores the World's dataclasses field by field: arrays as npz arrays, the rest as JSON,
rebuilt only as classes of mcpt (a class name from elsewhere makes the entry unusable).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import importlib
import json
import logging
import os
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from .. import cache
from ..scene import Scene
from . import obj

log = logging.getLogger("mcpt")

#: Mesh file suffixes whose every companion file is known (none, or the ones _companions names).
CACHEABLE_SUFFIXES = (".obj", ".ply", ".stl", ".off", ".serialized", ".glb", ".gltf")
#: Packages whose source shapes a world: their .py files are part of every key.
_SOURCE_PACKAGES = ("shapes", "scene", "shading")
_source_digests: dict[tuple, str] = {}


class Uncacheable(Exception):
    """The world holds something the entry format cannot store (then it is not cached)."""


def cached_world(scene: Scene, build: Callable[[Scene], object], enabled: bool | None = None):
    """``build(scene)`` (mcpt.shapes.world.load_world), through the cache when it is enabled."""
    if not cache.enabled(enabled):
        return build(scene)
    t0 = time.perf_counter()
    try:
        key = world_key(scene)
    except Exception as exc:  # noqa: BLE001 -- the cache must never stop a render
        log.warning("cache: no key for %s (%s: %s); building without the cache",
                    scene.source_path, type(exc).__name__, exc)
        key = None
    if key is None:
        return build(scene)
    store = cache.Store("world")
    hit = store.get(key)
    if hit is not None:
        world = _from_entry(scene, *hit)
        if world is not None:
            world.cache_key = key  # the packed buffers' cache (mcpt/gpu/pack_cache.py) builds on it
            world.stats["cache"] = "hit"
            world.stats["load_seconds"] = time.perf_counter() - t0
            return world
    world = build(scene)
    try:
        meta, arrays = _to_entry(world)
    except Exception as exc:  # noqa: BLE001 -- Uncacheable, or a texture gone since the build
        log.info("cache: world of %s not cached (%s: %s)", scene.source_path, type(exc).__name__, exc)
        return world
    store.put_behind(key, meta, arrays)
    world.cache_key = key
    world.stats["cache"] = "miss"
    return world


def world_key(scene: Scene) -> str | None:
    """The cache key of ``scene``'s world, or None when some file it reads cannot be followed."""
    doc = scene.model_dump(mode="json")
    doc.pop("render", None)
    doc.pop("name", None)
    doc["camera"] = {"position": doc["camera"]["position"]}
    files = {}
    # Mesh files first, with what they name: their digest and companions come from one read
    # (a mesh file is also a named file below; hashed there first, a 40 MB OBJ was read and
    # hashed twice on a cold key, issue #23).
    for spec in scene.meshes:
        if spec.file is None:
            continue
        path = Path(spec.file).resolve()
        if path.suffix.lower() not in CACHEABLE_SUFFIXES:
            return None
        files[str(path)], companions = cache.file_facts(
            path, lambda data, p=path: [str(c) for c in _companions(p, data)])
        for companion in companions or ():
            files[companion] = cache.file_digest(Path(companion))
    for f in _named_files(doc):
        if str(Path(f).resolve()) not in files:  # a mesh file, named by another path or the same
            files[f] = cache.file_digest(Path(f))
    return cache.key_of("world", doc, files, versions())


def _named_files(doc) -> list[str]:
    """Every string of the scene document that names an existing file by an absolute path: mesh
    files, textures, environment maps, and whatever file-valued key the scene format gains."""
    out = []
    stack = [doc]
    while stack:
        item = stack.pop()
        if isinstance(item, dict):
            stack.extend(item.values())
        elif isinstance(item, list):
            stack.extend(item)
        elif isinstance(item, str) and os.path.isabs(item) and os.path.isfile(item):
            out.append(item)
    return sorted(set(out))


def _companions(path: Path, data: bytes | None) -> list[Path]:
    """Files a mesh file names: an OBJ's MTL files (both readings of a name with spaces, as
    mcpt/shapes/obj.py resolves them), a .gltf's external buffers and images."""
    if data is None:
        return []
    out = []
    if path.suffix.lower() == ".obj":
        for spec in obj.mtllib_specs(data):
            out += [path.parent / spec] + [path.parent / name for name in spec.split()]
    elif path.suffix.lower() == ".gltf":
        try:
            doc = json.loads(data)
        except ValueError:
            return []
        for item in doc.get("buffers", []) + doc.get("images", []):
            uri = item.get("uri") if isinstance(item, dict) else None
            if isinstance(uri, str) and not uri.startswith("data:"):
                from urllib.parse import unquote

                out.append(path.parent / unquote(uri))
    return out


def versions(packages: tuple[str, ...] = _SOURCE_PACKAGES) -> dict:
    """What else shapes a result: the source of mcpt's ``packages`` (subfolders of mcpt/), numpy's
    and Assimp's versions."""
    if packages not in _source_digests:
        root, h = os.path.dirname(os.path.dirname(os.path.realpath(__file__))), hashlib.sha256()
        for pkg in packages:
            for parts in sorted(_py_files(root, pkg)):  # sorted by parts, as pathlib sorts
                with open(os.path.join(root, *parts), "rb") as f:
                    h.update(os.path.join(*parts).encode() + b"\0" + f.read())
        _source_digests[packages] = h.hexdigest()
    from .. import __version__

    return {"mcpt": __version__, "source": _source_digests[packages], "numpy": np.__version__,
            "assimp": _assimp_version()}


def _py_files(root: str, pkg: str) -> list[tuple[str, ...]]:
    """The .py files under ``root``/``pkg`` as path parts relative to ``root`` (os.walk with
    strings: pathlib's rglob and relative_to cost 10 ms of a 0.3 s warm set-up, issue #23)."""
    out = []
    for folder, _, names in os.walk(os.path.join(root, pkg)):
        rel = tuple(os.path.relpath(folder, root).split(os.sep))
        out += [(*rel, n) for n in names if n.endswith(".py")]
    return out


@functools.cache
def _assimp_version() -> str:
    """Assimp's package version, read once per process (the package metadata scan costs ~8 ms)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("assimp-py")
    except PackageNotFoundError:
        return "none"


def _to_entry(world) -> tuple[dict, dict[str, np.ndarray]]:
    arrays: dict[str, np.ndarray] = {}
    fields = {f.name: encode(getattr(world, f.name), arrays)
              for f in dataclasses.fields(world) if f.name != "scene"}
    deps = {str(t.path): cache.file_digest(t.path) for t in getattr(world, "textures", [])
            if getattr(t, "path", None) is not None}
    return {"class": class_name(world), "fields": fields, "deps": deps}, arrays


def _from_entry(scene: Scene, meta: dict, arrays: dict):
    """The world an entry holds, or None when it does not decode or a recorded file changed."""
    try:
        for path, digest in meta["deps"].items():
            if cache.file_digest(Path(path)) != digest:
                return None
        fields = {k: decode(v, arrays) for k, v in meta["fields"].items()}
        return construct(meta["class"], {"scene": scene, **fields})
    except Exception as exc:  # noqa: BLE001 -- an entry that does not decode is a miss
        log.info("cache: world entry unusable (%s: %s)", type(exc).__name__, exc)
        return None


def class_name(value) -> str:
    cls = type(value)
    if not cls.__module__.startswith("mcpt."):
        raise Uncacheable(f"{cls.__module__}.{cls.__qualname__} is not an mcpt class")
    return f"{cls.__module__}:{cls.__qualname__}"


def construct(name: str, fields: dict):
    module, _, qualname = name.partition(":")
    if not module.startswith("mcpt.") or "." in qualname:
        raise ValueError(f"refusing to build {name!r}")
    cls = getattr(importlib.import_module(module), qualname)
    if not dataclasses.is_dataclass(cls):
        raise ValueError(f"{name!r} is not a dataclass")
    init = {f.name for f in dataclasses.fields(cls) if f.init}
    made = cls(**{k: v for k, v in fields.items() if k in init})
    for k, v in fields.items():
        if k not in init:
            object.__setattr__(made, k, v)
    return made


def encode(value, arrays: dict):
    """A JSON-able description of ``value``; its arrays go to ``arrays``."""
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, np.ndarray):
        if value.dtype.hasobject:
            raise Uncacheable("an object array")
        name = f"a{len(arrays)}"
        arrays[name] = value
        return {"__a": name}
    if isinstance(value, np.generic):
        return {"__n": value.dtype.str, "v": value.item()}
    if isinstance(value, Path):
        return {"__p": str(value)}
    if isinstance(value, (set, frozenset)):
        items = [_encode_item(v, arrays) for v in value]
        return {"__s": sorted(items, key=lambda v: json.dumps(v, sort_keys=True)),
                "frozen": isinstance(value, frozenset)}
    if isinstance(value, (tuple, list)):
        items = [encode(v, arrays) for v in value]
        return {"__t": items} if isinstance(value, tuple) else items
    if isinstance(value, dict):
        if not all(isinstance(k, str) for k in value):
            raise Uncacheable("a dict with non-string keys")
        return {"__d": {k: encode(v, arrays) for k, v in value.items()}}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {"__c": class_name(value),
                "f": {f.name: encode(getattr(value, f.name), arrays) for f in dataclasses.fields(value)}}
    raise Uncacheable(f"a {type(value).__name__}")


def _encode_item(value, arrays: dict):
    """A set's item: hashable scalars only (an array has no place in a set)."""
    if not isinstance(value, (bool, int, float, str, type(None))):
        raise Uncacheable(f"a set holding a {type(value).__name__}")
    return encode(value, arrays)


def decode(value, arrays: dict):
    if isinstance(value, list):
        return [decode(v, arrays) for v in value]
    if not isinstance(value, dict):
        return value
    if "__a" in value:
        return arrays[value["__a"]]
    if "__n" in value:
        return np.dtype(value["__n"]).type(value["v"])
    if "__p" in value:
        return Path(value["__p"])
    if "__s" in value:
        items = [decode(v, arrays) for v in value["__s"]]
        return frozenset(items) if value["frozen"] else set(items)
    if "__t" in value:
        return tuple(decode(v, arrays) for v in value["__t"])
    if "__d" in value:
        return {k: decode(v, arrays) for k, v in value["__d"].items()}
    if "__c" in value:
        return construct(value["__c"], {k: decode(v, arrays) for k, v in value["f"].items()})
    raise ValueError(f"unknown entry item {sorted(value)}")

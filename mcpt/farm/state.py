"""Checkpoint files: what a render needs to carry on bit for bit, written atomically.

A state file (``<first output>.state.npz``, numpy's zip of arrays, no pickles) holds the float64
sums of whole chunks, the float32 target of the unfinished chunk, the passes done and a JSON
record of everything that decides the numbers: the seed, the bounces, the resolution, the compile
options, and a hash of the scene *content* (the validated scene with every file it names replaced by
the SHA-256 of its bytes, so moving the scene folder or another machine's path does not matter, but
editing a mesh does). ``--resume`` refuses, naming the first difference, when any of them changed.
The same record goes into the EXR header as ``mcpt:*`` keys, which is what ``mcpt merge`` compares.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path

import numpy as np

from ..errors import McptError
from .accumulate import Accumulator

FORMAT = 1


class StateError(McptError, ValueError):
    """A state file that is missing, unreadable, or from another scene or setting."""


class ResumeError(StateError):
    """A checkpoint that cannot be carried on by this render (another scene, setting or spp)."""


def _digest(path: Path, cache: dict) -> str:
    if path not in cache:
        h = hashlib.sha256()
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
        cache[path] = h.hexdigest()
    return cache[path]


def _content(value, cache):
    if isinstance(value, Path):
        return "sha256:" + _digest(value, cache) if value.is_file() else f"missing:{value.name}"
    if isinstance(value, dict):
        return {str(k): _content(v, cache) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_content(v, cache) for v in value]
    return value


def scene_hash(scene) -> str:
    """SHA-256 (16 hex digits) of what the scene draws, without the render settings (those are
    compared one by one, so a refusal can name them) and without the name."""
    data = scene.model_dump()
    data.pop("render", None)
    data.pop("name", None)
    data["camera"] = {k: v for k, v in data["camera"].items() if k != "resolution"}
    text = json.dumps(_content(data, {}), sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def settings(scene, *, features_mode: str = "scene", clamp: float | None = None,
             sampler: str = "sobol", aovs=(), samples_per_draw: int | None = None,
             digest: str | None = None) -> dict:
    """Everything besides the spp that decides a render's numbers, by name. ``aovs``: the AOVs
    computed (they decide the accumulation targets); recorded only when there are some, so
    checkpoints of plain renders read as before. ``samples_per_draw`` (Renderer.samples_per_draw)
    groups the samples into draws, so it decides the float32 sums' rounding: a checkpoint from a
    version that drew otherwise (or recorded nothing) is refused rather than resumed off by a bit.
    ``digest``: the scene_hash taken when the world was built (Prepared.scene_hash), else now."""
    cam, rs = scene.camera, scene.render
    out = {"scene_hash": digest or scene_hash(scene), "width": cam.width, "height": cam.height,
           "bounces": rs.bounces, "seed": rs.seed, "features_mode": features_mode,
           "sampler": sampler, "clamp": None if clamp is None else float(clamp),
           "samples_per_draw": samples_per_draw}
    if aovs:
        out["aov_targets"] = ",".join(aovs)
    return out


def mismatch(expected: dict, found: dict, keys=None, here: str = "this render",
             there: str = "the checkpoint") -> str | None:
    """'seed is 4 in this render but 3 in the checkpoint' for the first setting that differs."""
    for k in keys or expected:
        if str(expected.get(k)) != str(found.get(k)):
            if k not in found and expected.get(k) is not None:
                return f"{there} records no {k} (written by another version of mcpt)"
            if k == "scene_hash":
                return (f"the scene differs (geometry, materials, camera or a file it names; "
                        f"hash {expected.get(k)} in {here}, {found.get(k)} in {there})")
            return f"{k} is {expected.get(k)} in {here} but {found.get(k)} in {there}"
    return None


def state_path(output: str | Path) -> Path:
    return Path(f"{output}.state.npz")


def check_state_path(path: str | Path, *, resume: bool, overwrite: bool) -> Path:
    """Before any work (issue #24): a checkpoint that could never be written (a name too long for
    its temporary file, a folder where no file can be created, a state file that cannot be
    replaced) is one line, not an internal error after the render; and a checkpoint already there
    is replaced only when asked (``--overwrite``): a render without ``--resume`` would otherwise
    replace hours of passes with its own."""
    path = Path(path)
    if path.exists() and not resume and not overwrite:
        raise StateError(f"{path}: a checkpoint is already there: --resume carries it on, "
                         "--overwrite starts again and replaces it")
    folder = path.parent if str(path.parent) else Path(".")
    try:
        fd, probe = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise StateError(f"{path}: cannot write the checkpoint in {folder}: "
                         f"{exc.strerror or exc}") from None
    if path.exists() and not os.access(path, os.W_OK):  # e.g. immutable (chattr +i)
        raise StateError(f"{path}: the checkpoint cannot be replaced (not writable)")
    return path


def save(path: str | Path, acc: Accumulator, record: dict) -> None:
    """Write the state atomically (temporary file renamed over ``path``; removed on any failure,
    a signal included, so the previous checkpoint survives intact)."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    os.close(fd)
    # "done": the samples per pixel summed (Accumulator.spp), under the name format 1 gave it.
    meta = {"format": FORMAT, "done": acc.spp, "chunk": acc.chunk, **record}
    arrays = {"complete": acc.complete, "meta": np.frombuffer(json.dumps(meta).encode(), np.uint8)}
    if acc.partial is not None:
        arrays["partial"] = acc.partial
    try:
        with open(tmp, "wb") as f:
            np.savez(f, **arrays)
            f.flush()
            os.fsync(f.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp's 0600 is for the temporary name only
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def load(path: str | Path) -> tuple[Accumulator, dict]:
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(bytes(z["meta"]).decode())
            complete = np.array(z["complete"], np.float64)
            partial = np.array(z["partial"], np.float32) if "partial" in z.files else None
    except FileNotFoundError:
        raise StateError(f"{path}: no checkpoint to resume (render with --checkpoint SECONDS first)") from None
    except (OSError, ValueError, KeyError) as exc:
        raise StateError(f"{path}: not a readable mcpt checkpoint ({exc})") from None
    if meta.get("format") != FORMAT:
        raise StateError(f"{path}: checkpoint format {meta.get('format')} is not {FORMAT}")
    acc = Accumulator(complete, int(meta["done"]), partial, int(meta["chunk"]))
    return acc, meta


def resume(path: str | Path, record: dict, targets: int, spp: int,
           samples_per_draw: int) -> Accumulator:
    """The checkpoint at ``path``, checked against this render (``record``: its settings(),
    ``targets``: its accumulation targets, ``spp``: the samples per pixel asked for) and put back
    on the draw grid (Accumulator.rewind_to_draw_grid); :class:`ResumeError` names a difference."""
    acc, found = load(path)
    # aov_targets is recorded only when there are some: compare it both ways.
    both = [{"aov_targets": d.get("aov_targets", "none")} for d in (record, found)]
    why = mismatch(record, found) or mismatch(*both)
    if why:
        raise ResumeError(f"{path}: cannot resume: {why}")
    if acc.complete.shape[0] != targets:  # a checkpoint from before AOVs were recorded
        raise ResumeError(f"{path}: cannot resume: it holds {acc.complete.shape[0]} "
                          f"accumulation targets, this render {targets} (other --aov)")
    if acc.spp > spp:
        raise ResumeError(f"{path}: cannot resume: the checkpoint has {acc.spp} passes, "
                          f"more than the {spp} asked for")
    if acc.spp < spp:
        acc.rewind_to_draw_grid(samples_per_draw)
    return acc

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
import stat
import tempfile
from contextlib import contextmanager
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
            if k == "aov_targets":  # issue #24 item 19: a plain checkpoint is not "another version"
                had = f"with the AOVs {found[k]}" if found.get(k) else "without AOVs"
                return f"{there} was rendered {had}, {here} asks for {expected.get(k) or 'none'}"
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
    folder = path.parent if str(path.parent) else Path(".")
    try:
        name_max = os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError):
        name_max = 255
    if len(os.fsencode(path.name)) > name_max:  # exists() itself would fail (ENAMETOOLONG)
        raise StateError(f"{path}: cannot write the checkpoint in {folder}: its name has "
                         f"{len(os.fsencode(path.name))} bytes, more than the {name_max} a name may have here")
    if path.exists():
        _regular(path)  # a FIFO would block the set-up when opened (issue #24 item 9)
    if path.exists() and not resume and not overwrite:
        raise StateError(f"{path}: a checkpoint is already there: --resume carries it on, "
                         "--overwrite starts again and replaces it")
    try:
        fd, probe = tempfile.mkstemp(prefix=f".{path.name[:200]}.", suffix=".tmp", dir=folder)
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
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name[:200]}.", suffix=".tmp", dir=folder)
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


def _regular(path: Path) -> int:
    """The size of the state file; one that is not a regular file is refused before it is opened
    (issue #24 item 9: opening a FIFO blocked the set-up, and a stop signal did not end it)."""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise StateError(f"{path}: no checkpoint to resume (render with --checkpoint SECONDS first)") from None
    except OSError as exc:
        raise StateError(f"{path}: cannot read the checkpoint: {exc.strerror or exc}") from None
    if not stat.S_ISREG(info.st_mode):
        kind = ("a folder" if stat.S_ISDIR(info.st_mode) else "a FIFO" if stat.S_ISFIFO(info.st_mode)
                else "a socket" if stat.S_ISSOCK(info.st_mode) else "a device")
        raise StateError(f"{path}: is {kind}, not a checkpoint file")
    return info.st_size


@contextmanager
def _reading(path: Path):
    """Whatever numpy or zipfile raise on a truncated or altered file (EOFError, BadZipFile, a bad
    CRC, ...) is one line naming the file (issue #24 item 15: they were internal errors)."""
    try:
        yield
    except McptError:
        raise
    except Exception as exc:  # noqa: BLE001 - the readers raise varied types on damaged files
        what = " ".join(str(exc).split()) or type(exc).__name__
        raise StateError(f"{path}: a damaged checkpoint (truncated or altered: {what})") from None


def _damaged(path: Path, what: str) -> StateError:
    return StateError(f"{path}: a damaged checkpoint: {what}")


def _whole(meta: dict, key: str, least: int, path: Path) -> int:
    value = meta.get(key)
    if type(value) is not int or value < least:  # noqa: E721 - bool and float are refused
        raise _damaged(path, f"{key} is {json.dumps(value)}, not a whole number >= {least}")
    return value


def _meta(z, path: Path) -> dict:
    """The JSON record, checked before any sums are read."""
    if "meta" not in z.files:
        raise _damaged(path, "it lacks its record (meta)")
    if z.zip.getinfo("meta.npy").file_size > 1 << 20:
        raise _damaged(path, "its record (meta) is over 1 MiB")
    raw = z["meta"]
    if raw.dtype != np.uint8 or raw.ndim != 1:
        raise _damaged(path, "its record (meta) is not text")
    try:
        meta = json.loads(raw.tobytes().decode())
    except (UnicodeDecodeError, ValueError):
        raise _damaged(path, "its record (meta) is not JSON") from None
    if not isinstance(meta, dict):
        raise _damaged(path, "its record (meta) is not a JSON object")
    if meta.get("format") != FORMAT or type(meta.get("format")) is not int:  # noqa: E721
        raise StateError(f"{path}: checkpoint format {meta.get('format')} is not {FORMAT}")
    _whole(meta, "done", 0, path)
    _whole(meta, "chunk", 1, path)
    return meta


def _header(z, name: str, path: Path) -> tuple[tuple, np.dtype]:
    """The shape and type of one array, from its npy header (nothing of its data is read)."""
    if f"{name}.npy" not in z.zip.namelist():
        raise _damaged(path, f"it lacks the {name} sums")
    fmt = np.lib.format
    with z.zip.open(f"{name}.npy") as f:
        version = fmt.read_magic(f)
        if version not in ((1, 0), (2, 0)):
            raise _damaged(path, f"{name} is in npy format {version}")
        shape, _, kind = (fmt.read_array_header_1_0 if version == (1, 0) else fmt.read_array_header_2_0)(f)
    return tuple(shape), kind


def _array(z, name: str, dtype, shape: tuple, path: Path) -> np.ndarray:
    """One array of sums: its type and shape checked from its header before its data is read (a
    crafted shape allocates nothing), then its values finite (issue #24 item 15). ``shape``: that
    of the render's sums, its first entry (the targets) None for any."""
    found, kind = _header(z, name, path)
    if kind != np.dtype(dtype):
        raise _damaged(path, f"{name} holds {kind} values, mcpt writes {np.dtype(dtype)}")
    if len(found) != 4 or found[1:] != shape[1:] or found[0] < 1:
        expected = tuple("any" if n is None else n for n in shape)
        raise _damaged(path, f"{name} has shape {found}, this render's sums {expected}")
    if shape[0] is not None and found[0] != shape[0]:  # a checkpoint from before AOVs were recorded
        raise ResumeError(f"{path}: cannot resume: it holds {found[0]} accumulation targets, "
                          f"this render {shape[0]} (other --aov)")
    data = z[name]
    if not np.isfinite(data).all():
        raise _damaged(path, f"{name} holds NaN or infinite sums")
    return data


def load(path: str | Path, check=None, targets: int | None = None) -> tuple[Accumulator, dict]:
    """The checkpoint at ``path``, every field checked (issue #24 item 15: a damaged or crafted
    file was an internal error or a wrong image). ``check(meta)``: the caller's comparisons, made
    before the sums are read; ``targets``: the accumulation targets expected (default: as held)."""
    path = Path(path)
    if _regular(path) == 0:
        raise StateError(f"{path}: not an mcpt checkpoint (the file is empty)")
    with _reading(path):
        with open(path, "rb") as f:
            if f.read(4) != b"PK\x03\x04":  # numpy would try it as a pickle (and say so)
                raise StateError(f"{path}: not an mcpt checkpoint (not a zip archive of arrays)")
        with np.load(path, allow_pickle=False) as z:
            meta = _meta(z, path)
            if check is not None:
                check(meta)
            shape = (targets, _whole(meta, "height", 1, path), _whole(meta, "width", 1, path), 4)
            complete = _array(z, "complete", np.float64, shape, path)
            partial = (_array(z, "partial", np.float32, complete.shape, path)
                       if "partial" in z.files else None)
    done, chunk = meta["done"], meta["chunk"]
    # Accumulator.add's rule: the passes after the last whole chunk are the partial sums, only those.
    if (partial is None) != (done % chunk == 0):
        raise _damaged(path, f"done is {done} passes in chunks of {chunk} but "
                             + ("it has no partial sums" if partial is None else "it holds partial sums"))
    return Accumulator(complete, done, partial, chunk), meta


def resume(path: str | Path, record: dict, targets: int, spp: int,
           samples_per_draw: int, chunk: int | None = None) -> Accumulator:
    """The checkpoint at ``path``, checked against this render (``record``: its settings(),
    ``targets``: its accumulation targets, ``spp``: the samples per pixel asked for, ``chunk``:
    its passes per read-back) and put back on the draw grid (Accumulator.rewind_to_draw_grid);
    :class:`ResumeError` names a difference."""

    def check(found: dict) -> None:  # before the sums are read: a refusal names the setting
        # aov_targets is recorded only when there are some: compare it both ways.
        both = [{"aov_targets": d.get("aov_targets", "none")} for d in (record, found)]
        why = mismatch(record, found) or mismatch(*both)
        if not why and chunk is not None and found["chunk"] != chunk:  # it decides the float64 sums
            why = f"chunk is {chunk} in this render but {found['chunk']} in the checkpoint"
        if why:
            raise ResumeError(f"{path}: cannot resume: {why}")
        if found["done"] > spp:
            raise ResumeError(f"{path}: cannot resume: the checkpoint has {found['done']} passes, "
                              f"more than the {spp} asked for")

    acc, _ = load(path, check, targets)
    if acc.spp < spp:
        acc.rewind_to_draw_grid(samples_per_draw)
    return acc

"""A content-addressed store on disk: what a slow step made, kept under a key that hashes
everything the step read, so that a second render, a resume or a farm worker skips it (issue #23).

Where: ``$MCPT_CACHE_DIR``, else ``$XDG_CACHE_HOME/mcpt``, else ``~/.cache/mcpt``. Off with
``MCPT_CACHE=0`` (the CLI's ``--no-cache`` sets it). Size cap: ``MCPT_CACHE_MAX_MB`` (default
:data:`DEFAULT_MAX_MB`); the least recently used entries go first (a hit touches its entry).

An entry is one ``.npz`` file (numpy arrays, no pickle: nothing in it can run code), named by
its key, holding the arrays and a JSON header (format number, key, kind). Safety:

* written to a temporary file in the same folder and renamed over the entry (``os.replace`` is
  atomic on POSIX and Windows), so a reader, another farm worker or a crash mid-write never sees
  a partial entry; two workers writing the same key write the same content, the last rename wins;
* an entry that cannot be read (truncated, corrupt, another format, another key under this
  name) is a miss: it is deleted and written again, never trusted;
* a failure to write (full disk, read-only folder) is logged and costs only the cache.
"""

from __future__ import annotations

import hashlib
import io
import json
import logging
import mmap
import os
import struct
import tempfile
import threading
import time
import zipfile
import zlib
from collections.abc import Callable
from pathlib import Path

import numpy as np

from .parallel import ordered

log = logging.getLogger("mcpt")

#: Bumped whenever the layout of an entry changes: older entries then miss.
FORMAT = 1
DEFAULT_MAX_MB = 4096
_HEADER = "__mcpt_cache__"
_SUFFIX = ".npz"
#: A file's remembered digest is trusted only when taken this long after its last change (seconds).
_RACY_S = 2.0
#: Entry members at least this large (bytes) have their CRC checked on every core (mcpt/parallel.py).
_THREAD_CRC_BYTES = 1 << 22
#: Temporary files older than this (seconds) are leftovers of a crashed writer.
_STALE_TMP_S = 3600.0


def enabled(flag: bool | None = None) -> bool:
    """``flag`` if given, else on unless ``MCPT_CACHE`` is 0 / off / false / no."""
    if flag is not None:
        return bool(flag)
    return os.environ.get("MCPT_CACHE", "1").strip().lower() not in ("0", "off", "false", "no")


def cache_dir() -> Path:
    if os.environ.get("MCPT_CACHE_DIR"):
        return Path(os.environ["MCPT_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "mcpt"


def max_bytes() -> int:
    try:
        return int(float(os.environ.get("MCPT_CACHE_MAX_MB", DEFAULT_MAX_MB)) * 2**20)
    except ValueError:
        return DEFAULT_MAX_MB * 2**20


def file_digest(path: Path) -> str:
    """SHA-256 of a file's bytes ("missing" when it cannot be read: its appearing changes keys)."""
    return file_facts(path)[0]


def file_facts(path: Path, derive: Callable[[bytes], list] | None = None) -> tuple[str, list | None]:
    """(SHA-256 of the file's bytes or "missing", ``derive(bytes)``), remembered per file.

    Hashing a 40 MB OBJ costs 0.05-0.15 s, a third of a warm set-up, so the digest (and what
    ``derive`` found in the bytes) is kept in ``digests/`` under the file's path with its size,
    inode, mtime and ctime, and reused while they are unchanged. Like git's index it trusts that
    record only when it was taken more than :data:`_RACY_S` after the file's last change: two
    writes within one tick of the file system's clock leave the same mtime, so a record taken in
    that tick could miss the second write."""
    path = Path(path)
    try:
        st = path.stat()
    except OSError:
        return "missing", None
    sig = [st.st_size, st.st_ino, st.st_mtime_ns, st.st_ctime_ns]
    memo = cache_dir() / "digests" / (hashlib.sha256(str(path.resolve()).encode()).hexdigest()[:40] + ".json")
    want_derived = derive is not None
    try:
        rec = json.loads(memo.read_text())
        if (rec["path"] == str(path.resolve()) and rec["sig"] == sig and (rec["derived"] is not None) >= want_derived
                and rec["at_ns"] - max(st.st_mtime_ns, st.st_ctime_ns) > _RACY_S * 1e9):
            return rec["digest"], rec["derived"]
    except (OSError, ValueError, KeyError, TypeError):
        pass
    try:
        data = path.read_bytes()
    except OSError:
        return "missing", None
    digest, derived = hashlib.sha256(data).hexdigest(), (derive(data) if derive else None)
    _write_json(memo, {"path": str(path.resolve()), "sig": sig, "at_ns": time.time_ns(), "digest": digest,
                       "derived": derived})
    return digest, derived


def _write_json(path: Path, doc: dict) -> None:
    """Write a small JSON file atomically; failures are ignored (it is only a memo)."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".json")
        with os.fdopen(fd, "w") as f:
            json.dump(doc, f)
        os.replace(tmp, path)
    except OSError:
        pass


def key_of(*parts) -> str:
    """A hex key for JSON-able ``parts`` (the format number is part of every key)."""
    text = json.dumps([FORMAT, *parts], sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


class Store:
    """Entries of one kind (a subfolder name, e.g. "world") in the cache folder."""

    def __init__(self, kind: str, root: Path | None = None) -> None:
        self.kind = kind
        self.root = Path(root) if root is not None else cache_dir()
        self.folder = self.root / kind

    def path(self, key: str) -> Path:
        return self.folder / f"{key}{_SUFFIX}"

    def get(self, key: str) -> tuple[dict, dict[str, np.ndarray]] | None:
        """(header's ``meta``, arrays) of the entry ``key``, or None (missing or unusable).

        The arrays are read-only views of the file mapped into memory (:func:`_mapped_arrays`):
        what a caller never touches is never read, and nothing is copied."""
        path = self.path(key)
        _join(path)  # this process may still be writing it
        try:
            arrays = _mapped_arrays(path)
            header = json.loads(bytes(arrays.pop(_HEADER)).decode())
            if header.get("format") != FORMAT or header.get("key") != key or header.get("kind") != self.kind:
                raise ValueError("an entry of another format, key or kind")
        except FileNotFoundError:
            return None
        except Exception as exc:  # noqa: BLE001 -- whatever is wrong with the file, it is a miss
            log.info("cache: ignoring unusable entry %s (%s: %s)", path, type(exc).__name__, exc)
            _unlink(path)
            return None
        try:
            os.utime(path)  # least recently used goes first
        except OSError:
            pass
        return header.get("meta", {}), arrays

    def put_behind(self, key: str, meta: dict, arrays: dict[str, np.ndarray]) -> None:
        """:meth:`put` in a background thread: the render goes on while the entry is written
        (zlib's CRC and the file writes release the GIL). The arrays must not change meanwhile.
        The thread is not a daemon, so the interpreter finishes the write before it exits;
        :func:`wait` joins every pending write."""
        path = self.path(key)
        _join(path)
        thread = threading.Thread(target=self.put, args=(key, meta, arrays), name=f"mcpt-cache-{key[:8]}")
        with _PENDING_LOCK:
            _PENDING[path] = thread
        thread.start()

    def put(self, key: str, meta: dict, arrays: dict[str, np.ndarray]) -> Path | None:
        """Write the entry atomically; returns its path (None when writing failed)."""
        header = {"format": FORMAT, "key": key, "kind": self.kind, "meta": meta}
        payload = {_HEADER: np.frombuffer(json.dumps(header).encode(), np.uint8), **arrays}
        tmp = None
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=self.folder, prefix=".tmp-", suffix=_SUFFIX)
            with os.fdopen(fd, "wb") as f:
                _write_npz(f, payload)
            # No fsync: an entry a power cut truncates or zeroes fails its CRC check and is a miss.
            os.replace(tmp, self.path(key))
        except (OSError, ValueError) as exc:
            log.warning("cache: could not write %s (%s); continuing without it", self.path(key), exc)
            if tmp is not None:
                _unlink(Path(tmp))
            return None
        self.evict(keep=self.path(key))
        return self.path(key)

    def evict(self, keep: Path | None = None) -> None:
        """Delete least recently used entries (of every kind) until the cache fits its cap, and
        temporary files left by crashed writers."""
        entries, now = [], time.time()
        for p in self.root.glob(f"*/*{_SUFFIX}"):
            try:
                st = p.stat()
            except OSError:
                continue
            if p.name.startswith(".tmp-"):
                if now - st.st_mtime > _STALE_TMP_S:
                    _unlink(p)
                continue
            entries.append((st.st_mtime, st.st_size, p))
        total, cap = sum(e[1] for e in entries), max_bytes()
        for _, size, p in sorted(entries, key=lambda e: e[0]):
            if total <= cap:
                break
            if p != keep:
                _unlink(p)
                total -= size


_PENDING: dict[Path, threading.Thread] = {}
_PENDING_LOCK = threading.Lock()


def _join(path: Path) -> None:
    with _PENDING_LOCK:
        thread = _PENDING.pop(path, None)
    if thread is not None and thread is not threading.current_thread():
        thread.join()


def wait() -> None:
    """Wait for every entry this process is writing in the background (:meth:`Store.put_behind`)."""
    with _PENDING_LOCK:
        threads = list(_PENDING.values())
        _PENDING.clear()
    for thread in threads:
        thread.join()


def _write_npz(f, arrays: dict[str, np.ndarray]) -> None:
    """An uncompressed ``.npz`` (what np.savez writes, np.load reads) written from the arrays'
    own memory: np.savez copies every array through ``tobytes`` in 16 MiB chunks first."""
    with zipfile.ZipFile(f, "w", zipfile.ZIP_STORED, allowZip64=True) as z:
        for name, arr in arrays.items():
            arr = np.asarray(arr)
            if not arr.flags.c_contiguous:
                arr = arr.copy(order="C")
            if arr.dtype.hasobject:
                raise ValueError(f"array {name!r} holds objects")
            header = io.BytesIO()
            np.lib.format.write_array_header_2_0(header, np.lib.format.header_data_from_array_1_0(arr))
            with z.open(f"{name}.npy", "w", force_zip64=True) as member:
                member.write(header.getvalue())
                if arr.size:
                    member.write(memoryview(arr.reshape(-1)).cast("B"))


def _mapped_arrays(path: Path) -> dict[str, np.ndarray]:
    """The arrays of an uncompressed ``.npz`` as read-only views of the file mapped into memory.

    np.load would copy every array out of the zip (allocating and faulting in 170 MB for a 10^6
    triangle scene costs 0.5 s on a loaded machine); a stored zip member is one contiguous run of
    the file, so each array is the ``.npy`` payload at its offset. Each member is checked against
    the CRC-32 the zip records for it (zlib's crc32 runs at GB/s), so a damaged entry is refused
    like a truncated one. The mapping stays valid after the entry is replaced or evicted (POSIX
    keeps an unlinked file's pages while they are mapped)."""
    out, members = {}, []
    with open(path, "rb") as f, zipfile.ZipFile(f) as z:
        mm = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
        for info in z.infolist():
            if info.compress_type != zipfile.ZIP_STORED or not info.filename.endswith(".npy"):
                raise ValueError(f"member {info.filename!r} is not a stored .npy")
            name_len, extra_len = struct.unpack("<HH", mm[info.header_offset + 26:info.header_offset + 30])
            start = info.header_offset + 30 + name_len + extra_len
            end = start + info.file_size
            if end > len(mm):
                raise ValueError(f"member {info.filename!r} is damaged")
            members.append((info, start, end))
        _check_crcs(mm, members)
        for info, start, end in members:
            f.seek(start)
            version = np.lib.format.read_magic(f)
            shape, fortran, dtype = (np.lib.format.read_array_header_1_0(f) if version == (1, 0)
                                     else np.lib.format.read_array_header_2_0(f))
            if dtype.hasobject:
                raise ValueError(f"member {info.filename!r} holds objects")
            count = int(np.prod(shape, dtype=np.int64))
            if f.tell() + count * dtype.itemsize != end:
                raise ValueError(f"member {info.filename!r} has the wrong size")
            arr = np.frombuffer(mm, dtype, count, f.tell()).reshape(shape, order="F" if fortran else "C")
            out[info.filename[:-4]] = arr
    return out


def _check_crcs(mm: mmap.mmap, members: list) -> None:
    """Check each ``(ZipInfo, start, end)`` member's bytes against its recorded CRC-32, the large
    members spread over threads: zlib's crc32 releases the GIL, and checking (with the page faults
    of first touching the mapping) is a third of a warm 10^6-triangle set-up on one core (issue #23)."""
    def bad(member) -> bool:
        info, start, end = member
        return zlib.crc32(memoryview(mm)[start:end]) != info.CRC

    large = sorted((m for m in members if m[2] - m[1] >= _THREAD_CRC_BYTES), key=lambda m: m[1] - m[2])
    small = [m for m in members if m[2] - m[1] < _THREAD_CRC_BYTES]
    for member, damaged in zip(large + small, ordered(bad, large) + [bad(m) for m in small]):
        if damaged:
            raise ValueError(f"member {member[0].filename!r} is damaged")


def _unlink(path: Path) -> None:
    try:
        path.unlink()
    except OSError:
        pass

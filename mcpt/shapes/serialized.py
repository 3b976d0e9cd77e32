"""Mitsuba's ``.serialized`` mesh format, read without Mitsuba (its documented layout).

A file is a sequence of shapes, each ``uint16 0x041C`` (format id), ``uint16 version`` (3 or 4),
then one zlib stream holding::

    uint32  flags      0x0001 vertex normals, 0x0002 uvs, 0x0008 vertex colours,
                       0x0010 "use face normals", 0x1000 float32, 0x2000 float64
    (v4)    UTF-8 shape name, NUL-terminated
    uint64  vertex count V,  uint64 triangle count T
    V*3 positions, [V*3 normals], [V*2 uvs], [V*3 colours]   (float32 or float64)
    T*3 indices (uint32; uint64 when V > 2^32 - 1)

and the file ENDS with a dictionary: one offset per shape (uint64 in v4, uint32 in v3) and the
uint32 shape count. All little-endian. ``shape_index`` picks the shape through that dictionary.
Decompression is incremental and bounded by the sizes the header announces (a bomb or a lie is
refused before memory is spent on it).
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .mesh import MeshError

MAGIC = 0x041C
FLAG_NORMALS, FLAG_UVS, FLAG_COLOURS, FLAG_FACE_NORMALS = 0x0001, 0x0002, 0x0008, 0x0010
FLAG_SINGLE, FLAG_DOUBLE = 0x1000, 0x2000
#: Largest decompressed shape accepted (bytes): bounds memory whatever the header claims.
MAX_SHAPE_BYTES = 4 * 2**30


class SerializedError(MeshError):
    """A .serialized file that cannot be read (one line naming the file and the shape)."""


@dataclass(frozen=True)
class SerializedMesh:
    """One shape: positions (V, 3) float64, faces (T, 3) int64, optional normals/uvs (float64),
    ``face_normals``: the file's hint to shade flat."""

    name: str
    positions: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None
    uvs: np.ndarray | None
    face_normals: bool


def shape_count(path: Path) -> tuple[int, list[int]]:
    """(version, offsets of every shape) from the end-of-file dictionary."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            head = fh.read(4)
            fh.seek(0, 2)
            size = fh.tell()
            if len(head) < 4 or size < 8:
                raise SerializedError(f"{path}: too short for a .serialized file ({size} bytes)")
            magic, version = struct.unpack("<HH", head)
            if magic != MAGIC:
                raise SerializedError(f"{path}: not a Mitsuba .serialized file (id {magic:#06x}, "
                                      f"expected {MAGIC:#06x})")
            if version not in (3, 4):
                raise SerializedError(f"{path}: .serialized version {version} (mcpt reads 3 and 4)")
            fh.seek(size - 4)
            (count,) = struct.unpack("<I", fh.read(4))
            width = 8 if version == 4 else 4
            if count == 0 or count * width + 4 > size:
                raise SerializedError(f"{path}: corrupt shape dictionary at the end of the file "
                                      f"({count} shapes in {size} bytes)")
            fh.seek(size - 4 - count * width)
            offsets = list(struct.unpack(f"<{count}{'Q' if version == 4 else 'I'}",
                                         fh.read(count * width)))
    except OSError as exc:
        raise SerializedError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if any(o >= size for o in offsets):
        raise SerializedError(f"{path}: corrupt shape dictionary (an offset past the end)")
    return version, offsets


class _Stream:
    """Bounded incremental zlib reads from a file position."""

    def __init__(self, fh, where: str):
        self.fh, self.where = fh, where
        self.z = zlib.decompressobj()
        self.buf = b""

    def read(self, n: int) -> bytes:
        while len(self.buf) < n:
            if self.z.unconsumed_tail:
                chunk = self.z.unconsumed_tail
            else:
                chunk = self.fh.read(1 << 20)
                if not chunk:
                    raise SerializedError(f"{self.where}: truncated (the data ends before the "
                                          "sizes its header gives)")
            try:
                self.buf += self.z.decompress(chunk, n - len(self.buf))
            except zlib.error as exc:
                raise SerializedError(f"{self.where}: corrupt zlib stream: {exc}") from None
            if self.z.eof and len(self.buf) < n:
                raise SerializedError(f"{self.where}: truncated (the data ends before the sizes "
                                      "its header gives)")
        out, self.buf = self.buf[:n], self.buf[n:]
        return out


def _header(fh, path: Path, shape_index: int, version: int, offsets: list[int]):
    """(where, zlib stream positioned after the header, flags, name, vertex count, triangle
    count) of shape ``shape_index``; ``fh`` is the open file, ``version, offsets`` its
    :func:`shape_count`."""
    if not 0 <= shape_index < len(offsets):
        raise SerializedError(f"{path}: shape_index {shape_index} out of range (the file holds "
                              f"{len(offsets)} shape(s))")
    where = f"{path}: shape {shape_index}"
    fh.seek(offsets[shape_index])
    magic, ver = struct.unpack("<HH", fh.read(4))
    if magic != MAGIC or ver != version:
        raise SerializedError(f"{where}: no shape header at offset {offsets[shape_index]}")
    s = _Stream(fh, where)
    (flags,) = struct.unpack("<I", s.read(4))
    name = ""
    if version == 4:
        raw = bytearray()
        while (c := s.read(1)) != b"\0":
            raw += c
            if len(raw) > 4096:
                raise SerializedError(f"{where}: shape name longer than 4096 bytes")
        name = raw.decode("utf-8", "replace")
    nv, nt = struct.unpack("<QQ", s.read(16))
    return where, s, flags, name, nv, nt


def triangle_count(path: str | Path, shape_index: int = 0) -> int:
    """The triangle count shape ``shape_index``'s header announces: a few hundred bytes
    decompressed (issue #24: a scene's size is checked before its geometry is read)."""
    path = Path(path)
    version, offsets = shape_count(path)
    with open(path, "rb") as fh:
        return int(_header(fh, path, shape_index, version, offsets)[5])


def read_serialized(path: str | Path, shape_index: int = 0) -> SerializedMesh:
    """Shape ``shape_index`` of the .serialized file at ``path`` (see the module doc)."""
    path = Path(path)
    version, offsets = shape_count(path)
    with open(path, "rb") as fh:
        where, s, flags, name, nv, nt = _header(fh, path, shape_index, version, offsets)
        real = np.float64 if flags & FLAG_DOUBLE else np.float32
        if not flags & (FLAG_SINGLE | FLAG_DOUBLE):
            raise SerializedError(f"{where}: flags {flags:#x} give neither single nor double precision")
        index = np.uint64 if nv > 2**32 - 1 else np.uint32
        per_vertex = 3 + 3 * bool(flags & FLAG_NORMALS) + 2 * bool(flags & FLAG_UVS) + 3 * bool(flags & FLAG_COLOURS)
        total = nv * per_vertex * np.dtype(real).itemsize + nt * 3 * np.dtype(index).itemsize
        if total > MAX_SHAPE_BYTES:
            raise SerializedError(f"{where}: {nv} vertices and {nt} triangles ({total / 2**30:.1f} GiB) "
                                  f"exceed mcpt's limit of {MAX_SHAPE_BYTES / 2**30:.0f} GiB per shape")

        def array(count: int, dtype, cols: int) -> np.ndarray:
            return np.frombuffer(s.read(count * cols * np.dtype(dtype).itemsize), dtype).reshape(-1, cols)

        positions = array(nv, real, 3).astype(np.float64)
        normals = array(nv, real, 3).astype(np.float64) if flags & FLAG_NORMALS else None
        uvs = array(nv, real, 2).astype(np.float64) if flags & FLAG_UVS else None
        if flags & FLAG_COLOURS:
            array(nv, real, 3)  # vertex colours: read past, mcpt does not use them
        faces = array(nt, index, 3).astype(np.int64)
    if nt and int(faces.max()) >= nv:
        raise SerializedError(f"{where}: vertex index {int(faces.max())} out of range [0, {nv})")
    if not np.isfinite(positions).all():
        raise SerializedError(f"{where}: non-finite vertex positions")
    return SerializedMesh(name, positions, faces, normals, uvs, bool(flags & FLAG_FACE_NORMALS))

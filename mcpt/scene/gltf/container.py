"""A glTF 2.0 file as read: the JSON document, its buffers, and one-line errors naming the element.

``.gltf`` is JSON whose buffers are files beside it or ``data:`` URIs (base64); ``.glb`` is the
binary container (glTF 2.0 spec, section 4.4: a 12-byte header, a JSON chunk, an optional BIN
chunk that is buffer 0). Sizes are checked before anything is allocated: the file against
:data:`MAX_FILE_BYTES`, every buffer against its declared ``byteLength`` and
:data:`MAX_BUFFER_BYTES`, so a lying or hostile file costs at most its own size in memory.
Buffers are read on first use (:meth:`Gltf.buffer`); :func:`open_gltf` keeps the last few files
read, so the scene reader and the geometry reader share one reading of the file.
"""

from __future__ import annotations

import base64
import binascii
import functools
import json
import struct
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote

from ..diagnostics import SceneError

#: Largest .gltf / .glb file read (bytes).
MAX_FILE_BYTES = 2**31
#: Largest buffer (bytes): 2 GiB, far above any scene mcpt can render.
MAX_BUFFER_BYTES = 2**31
GLB_MAGIC = 0x46546C67   # "glTF"
CHUNK_JSON = 0x4E4F534A  # "JSON"
CHUNK_BIN = 0x004E4942   # "BIN\0"


class GltfError(SceneError):
    """A glTF file mistake or a refused feature: ``file: element: reason`` (JSON has no lines
    worth naming; the element path, e.g. ``accessors[3]``, locates it)."""


@dataclass
class Gltf:
    """A parsed glTF file. ``doc``: the JSON document; ``bin``: the GLB BIN chunk (or None)."""

    path: Path
    doc: dict
    bin: bytes | None = None
    _buffers: dict = field(default_factory=dict)
    #: Values derived from ``doc`` once (geometry.py's primitive numbering).
    memo: dict = field(default_factory=dict)

    def error(self, where: str, reason: str) -> GltfError:
        return GltfError(self.path, None, where, reason)

    def items(self, kind: str) -> list:
        """The top-level array ``kind`` (``accessors``, ``nodes``, ...), [] when absent."""
        value = self.doc.get(kind, [])
        if not isinstance(value, list):
            raise self.error(kind, f"expected an array, got {type(value).__name__}")
        return value

    def get(self, kind: str, index, where: str = "") -> dict:
        """``kind[index]`` as a JSON object; a bad reference is one line naming ``where``."""
        items = self.items(kind)
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(items):
            raise self.error(where or f"{kind}[{index}]",
                             f"{kind}[{index!r}] does not exist ({len(items)} {kind})")
        item = items[index]
        if not isinstance(item, dict):
            raise self.error(f"{kind}[{index}]", f"expected an object, got {type(item).__name__}")
        return item

    def buffer_length(self, index: int, where: str = "") -> int:
        """The declared ``byteLength`` of buffer ``index`` (checked against the data when read)."""
        buf = self.get("buffers", index, where)
        n = buf.get("byteLength")
        if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_BUFFER_BYTES:
            raise self.error(f"buffers[{index}]", f"byteLength {n!r} is not an integer in [1, {MAX_BUFFER_BYTES}]")
        return n

    def buffer(self, index: int) -> memoryview:
        """The bytes of buffer ``index`` (exactly ``byteLength`` of them), read once."""
        if index not in self._buffers:
            self._buffers[index] = memoryview(self._read_buffer(index))
        return self._buffers[index]

    def _read_buffer(self, index: int) -> bytes:
        where = f"buffers[{index}]"
        length = self.buffer_length(index)
        uri = self.get("buffers", index).get("uri")
        if uri is None:
            if index != 0 or self.bin is None:
                raise self.error(where, "no uri, and only buffer 0 of a .glb may use the BIN chunk")
            data = self.bin
        elif not isinstance(uri, str):
            raise self.error(where, f"uri must be a string, got {type(uri).__name__}")
        elif uri.startswith("data:"):
            data = decode_data_uri(self, uri, where)
        else:
            data = read_beside(self, uri, where, length)
        if len(data) < length:
            raise self.error(where, f"byteLength {length} but the data holds only {len(data)} bytes")
        return data[:length]


def obj(value) -> dict:
    """``value`` if it is a JSON object, else {} (optional objects such as ``extensions``)."""
    return value if isinstance(value, dict) else {}


def decode_data_uri(g: Gltf, uri: str, where: str) -> bytes:
    """The bytes of a ``data:[mime];base64,...`` URI."""
    head, sep, payload = uri.partition(",")
    if not sep or not head.endswith(";base64"):
        raise g.error(where, "a data: URI must be base64 (data:<mime>;base64,...)")
    try:
        return base64.b64decode(payload, validate=True)
    except (binascii.Error, ValueError):
        raise g.error(where, "malformed base64 in the data: URI") from None


def read_beside(g: Gltf, uri: str, where: str, limit: int) -> bytes:
    """The first ``limit`` bytes of the file a relative ``uri`` names (beside the glTF)."""
    if "://" in uri:
        raise g.error(where, f"uri {uri!r}: only files beside the glTF and data: URIs are read")
    path = g.path.parent / unquote(uri)
    try:
        with open(path, "rb") as f:
            return f.read(limit)
    except OSError as exc:
        raise g.error(where, f"cannot read {path}: {exc.strerror or exc}") from None


def _glb_chunks(path: Path, data: bytes) -> tuple[bytes, bytes | None]:
    """(JSON chunk, BIN chunk or None) of a .glb file."""
    if len(data) < 20:
        raise GltfError(path, None, "", f"{len(data)} bytes: too short for a .glb (header and JSON chunk)")
    magic, version, length = struct.unpack_from("<III", data, 0)
    if magic != GLB_MAGIC:
        raise GltfError(path, None, "", "not a .glb file (no 'glTF' magic)")
    if version != 2:
        raise GltfError(path, None, "", f"GLB version {version}: mcpt reads glTF 2.0")
    if length > len(data):
        raise GltfError(path, None, "", f"the header says {length} bytes but the file has {len(data)}")
    chunks, offset = [], 12
    while offset + 8 <= length:
        size, kind = struct.unpack_from("<II", data, offset)
        if offset + 8 + size > length:
            raise GltfError(path, None, f"chunk at byte {offset}",
                            f"{size} bytes claimed, {length - offset - 8} left in the file")
        chunks.append((kind, data[offset + 8:offset + 8 + size]))
        offset += 8 + size + (-size % 4)
    if not chunks or chunks[0][0] != CHUNK_JSON:
        raise GltfError(path, None, "", "the first GLB chunk must be JSON")
    bins = [c for k, c in chunks[1:] if k == CHUNK_BIN]
    return chunks[0][1], (bins[0] if bins else None)


def _parse(path: Path) -> Gltf:
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise GltfError(path, None, "", f"{size} bytes: larger than mcpt reads ({MAX_FILE_BYTES})")
        data = path.read_bytes()
    except OSError as exc:
        raise GltfError(path, None, "", f"cannot read the glTF file: {exc.strerror or exc}") from None
    binary = None
    if data[:4] == b"glTF":
        text, binary = _glb_chunks(path, data)
    else:
        text = data
    try:
        doc = json.loads(text.decode("utf-8-sig"))
    except UnicodeDecodeError as exc:
        raise GltfError(path, None, "", f"the JSON is not UTF-8 (byte {exc.start})") from None
    except json.JSONDecodeError as exc:
        raise GltfError(path, exc.lineno, "", f"malformed JSON: {exc.msg}") from None
    except RecursionError:
        raise GltfError(path, None, "", "malformed JSON: nested too deeply") from None
    if not isinstance(doc, dict):
        raise GltfError(path, None, "", "the JSON must be an object")
    asset = doc.get("asset")
    version = asset.get("version") if isinstance(asset, dict) else None
    if not isinstance(version, str) or not version.startswith("2."):
        raise GltfError(path, None, "asset.version", f"{version!r}: mcpt reads glTF 2.0")
    return Gltf(path, doc, binary)


@functools.lru_cache(maxsize=4)
def _cached(path: str, mtime_ns: int, size: int) -> Gltf:
    return _parse(Path(path))


def open_gltf(path: str | Path) -> Gltf:
    """The parsed glTF file at ``path``; the same object while the file is unchanged."""
    path = Path(path).resolve()
    try:
        st = path.stat()
    except OSError as exc:
        raise GltfError(path, None, "", f"cannot read the glTF file: {exc.strerror or exc}") from None
    if not path.is_file():
        raise GltfError(path, None, "", "not a regular file")
    return _cached(str(path), st.st_mtime_ns, st.st_size)

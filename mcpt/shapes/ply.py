"""PLY meshes read by mcpt itself (issue #24 item 14), as a :class:`RawMesh` like Assimp's.

Assimp's PLY reader skips whitespace before binary data, so a binary file whose first byte of data
happens to be 0x09-0x0d or 0x20 (a first x of -2.4718659 is ``0d 33 1e c0``) was read shifted: it
failed ("point or line primitives", an index out of range) or, where the shifted data stayed in
range, loaded garbled without a word. Here the data starts exactly after the ``end_header`` line.

Reads ``ascii``, ``binary_little_endian`` and ``binary_big_endian``: the ``vertex`` element's x, y,
z (any scalar type), optional nx, ny, nz and a UV pair (u/v, s/t or texture_u/texture_v), and the
``face`` element's ``vertex_indices`` (or ``vertex_index``) list, any count and index types;
polygons are split as a fan (0, i, i+1). Other elements and properties (lists too) are skipped.
Declared sizes are checked against the bytes (or numbers) left before anything is allocated.

What Assimp made of a PLY that loaded is kept (tests/test_ply.py compares the two): only the
vertices faces use, identical vertices (position, normal, UV) joined, in file order.
"""

from __future__ import annotations

import operator
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .raw_mesh import MeshError, MeshMaterial, RawMesh, RawPart

#: PLY scalar types (the 1.0 names and the sized aliases) -> numpy type codes.
TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
         "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
         "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
_STRUCT = {"i1": "b", "u1": "B", "i2": "h", "u2": "H", "i4": "i", "u4": "I", "f4": "f", "f8": "d"}
#: Format name -> byte order (None: text).
FORMATS = {"ascii": None, "binary_little_endian": "<", "binary_big_endian": ">"}
UV_NAMES = (("u", "v"), ("s", "t"), ("texture_u", "texture_v"))
FACE_LISTS = ("vertex_indices", "vertex_index")


class PlyError(MeshError):
    """A PLY file that cannot be read (one line naming the file, and the header line if any)."""


@dataclass
class Prop:
    name: str
    type: str  # numpy code of the value(s)
    count: str | None = None  # numpy code of a list's length; None: a scalar


@dataclass
class Element:
    name: str
    count: int
    props: list[Prop] = field(default_factory=list)


@dataclass
class Header:
    order: str | None  # "<", ">" or None (ascii)
    elements: list[Element]
    data_start: int  # offset of the first byte after the end_header line


@dataclass
class Table:  # one element's data: scalars by name (R,), lists by name as (lengths (R,), flat values)
    scalars: dict[str, np.ndarray] = field(default_factory=dict)
    lists: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)


def read_ply(path: Path, *, need_normals: bool = False) -> RawMesh:
    """The mesh of a PLY file (the reader contract of mesh.read_geometry); raises PlyError."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise PlyError(f"{path}: cannot read: {exc.strerror or exc}") from None
    header = parse_header(path, data)
    tables = read_body(path, data, header)
    vertex = tables.get("vertex", Table()).scalars
    if not all(c in vertex for c in "xyz"):
        raise PlyError(f"{path}: no 'vertex' element with scalar x, y and z properties")
    positions = np.stack([vertex[c] for c in "xyz"], 1).astype(np.float64)
    normals = (np.stack([vertex[c] for c in ("nx", "ny", "nz")], 1).astype(np.float64)
               if all(c in vertex for c in ("nx", "ny", "nz")) else None)
    uvs = next((np.stack([vertex[u], vertex[v]], 1).astype(np.float64)
                for u, v in UV_NAMES if u in vertex and v in vertex), None)
    face = tables.get("face", Table()).lists
    name = next((n for n in FACE_LISTS if n in face), None)
    if name is None or len(face[name][0]) == 0:
        raise PlyError(f"{path}: contains no triangles (no 'face' element with a vertex_indices list)")
    triangles = _fan(path, *face[name], len(positions))
    positions, normals, uvs, triangles = _join(positions, normals, uvs, triangles)
    part = RawPart("sub-mesh #0", positions, triangles, 0, normals if need_normals else None, uvs)
    return RawMesh(path, [part], [MeshMaterial("")])


def parse_header(path: Path, data: bytes) -> Header:
    """The elements and format of the header; the data starts right after "end_header\\n"."""
    if not (data.startswith(b"ply\n") or data.startswith(b"ply\r\n")):
        raise PlyError(f"{path}: not a PLY file (it does not start with a 'ply' line)")
    pos, line, order, elements = 0, 0, "", []
    while True:
        nl = data.find(b"\n", pos)
        if nl < 0:
            raise PlyError(f"{path}: the PLY header has no end_header line")
        raw, pos, line = data[pos:nl], nl + 1, line + 1
        where = f"{path}:{line}"
        words = raw.decode("latin-1").split()  # a comment may hold any byte (an author's name)
        if line == 1 or not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "end_header":
            break
        if words[0] == "format":
            if len(words) < 2 or words[1] not in FORMATS:
                raise PlyError(f"{where}: unknown PLY format {' '.join(words[1:])!r} (mcpt reads "
                               f"{', '.join(FORMATS)})")
            order = FORMATS[words[1]]
        elif words[0] == "element":
            elements.append(_element(words, where))
        elif words[0] == "property":
            if not elements:
                raise PlyError(f"{where}: a property before any element")
            elements[-1].props.append(_property(words, where))
        # Any other keyword cannot change the data's layout: ignored, as other readers do.
    if order == "":
        raise PlyError(f"{path}: the PLY header has no format line")
    return Header(order, elements, pos)


def _element(words: list[str], where: str) -> Element:
    try:
        count = int(words[2]) if len(words) == 3 else -1
    except ValueError:
        count = -1
    if count < 0:
        raise PlyError(f"{where}: expected 'element <name> <count>', got {' '.join(words)!r}")
    return Element(words[1], count)


def _property(words: list[str], where: str) -> Prop:
    if len(words) == 5 and words[1] == "list":
        if words[2] not in TYPES or TYPES[words[2]][0] == "f":
            raise PlyError(f"{where}: a list length of type {words[2]!r} (an integer type is needed)")
        if words[3] not in TYPES:
            raise PlyError(f"{where}: unknown property type {words[3]!r}")
        return Prop(words[4], TYPES[words[3]], TYPES[words[2]])
    if len(words) != 3 or words[1] == "list":
        raise PlyError(f"{where}: expected 'property <type> <name>' or 'property list <type> <type> "
                       f"<name>', got {' '.join(words)!r}")
    if words[1] not in TYPES:
        raise PlyError(f"{where}: unknown property type {words[1]!r}")
    return Prop(words[2], TYPES[words[1]])


def read_body(path: Path, data: bytes, header: Header) -> dict[str, Table]:
    """Every element's data in file order (the vertex and face tables are kept, others skipped)."""
    tables, pos = {}, header.data_start
    if header.order is None:
        data = _numbers(path, data, pos)
        pos = 0
    for el in header.elements:
        read = _ascii_element if header.order is None else _binary_element
        table, pos = read(path, data, pos, el, header.order)
        if el.name in ("vertex", "face") and el.name not in tables:
            tables[el.name] = table
    return tables


def _numbers(path: Path, data: bytes, start: int) -> np.ndarray:
    """Every number of an ASCII body, as float64 (exact for integers up to 2^53)."""
    body = data[start:]
    try:
        return np.fromstring(body, dtype=np.float64, sep=" ")
    except ValueError:
        pass
    head_lines = data.count(b"\n", 0, start)
    for i, text in enumerate(body.split(b"\n")):
        for tok in text.split():
            try:
                float(tok)
            except ValueError:
                raise PlyError(f"{path}:{head_lines + i + 1}: {tok.decode(errors='replace')!r} is not a "
                               "number") from None
    raise PlyError(f"{path}: unreadable ASCII data")


def _truncated(path: Path, el: Element, row: int) -> PlyError:
    return PlyError(f"{path}: truncated: element {el.name!r} row {row} of {el.count} runs past the "
                    "end of the data")


def _binary_element(path: Path, data: bytes, pos: int, el: Element, order: str) -> tuple[Table, int]:
    left = len(data) - pos
    least = sum(np.dtype(p.count or p.type).itemsize for p in el.props)  # a row, every list empty
    if el.count * least > left:
        raise PlyError(f"{path}: element {el.name!r} declares {el.count} rows of at least {least} bytes, "
                       f"more than the {left} bytes of data left")
    if el.count == 0:
        return Table(), pos
    # Fast path: every row's lists as long as row 0's (all triangles, say): one structured read.
    lengths, end = {}, pos
    try:
        for i, p in enumerate(el.props):
            if p.count is not None:
                (lengths[i],) = struct.unpack_from(order + _STRUCT[p.count], data, end)
                end += np.dtype(p.count).itemsize + max(lengths[i], 0) * np.dtype(p.type).itemsize
            else:
                end += np.dtype(p.type).itemsize
    except struct.error:
        raise _truncated(path, el, 0) from None
    if min(lengths.values(), default=0) >= 0 and el.count * (end - pos) <= left:
        fields = []
        for i, p in enumerate(el.props):
            if p.count is not None:
                fields.append((f"n{i}", order + p.count))
            fields.append((f"v{i}", order + p.type, (lengths[i],) if p.count is not None else ()))
        rows = np.frombuffer(data, np.dtype(fields), el.count, pos)
        if all((rows[f"n{i}"] == n).all() for i, n in lengths.items()):
            table = Table()
            for i, p in enumerate(el.props):
                column = rows[f"v{i}"]
                if p.count is None:
                    table.scalars.setdefault(p.name, column.astype(column.dtype.newbyteorder("=")))
                else:
                    table.lists.setdefault(p.name, (np.full(el.count, lengths[i], np.int64), column.reshape(-1)))
            return table, end + (el.count - 1) * (end - pos)
    return _binary_rows(path, data, pos, el, order)


def _binary_rows(path: Path, data: bytes, pos: int, el: Element, order: str) -> tuple[Table, int]:
    """Lists of varying lengths (polygons of mixed sizes): a loop finds where each property of each
    row starts (1M mixed triangles and quads: 2.2 s against 3.9-5.8 s unpacking every value, 2 loaded
    cores), numpy gathers the values."""
    size = [np.dtype(p.count or p.type).itemsize for p in el.props]
    item = [np.dtype(p.type).itemsize for p in el.props]
    readers = [None if p.count is None else _count_reader(order + p.count) for p in el.props]
    starts, row, end, props = [], 0, len(data), range(len(el.props))
    try:
        for row in range(el.count):
            for i in props:
                starts.append(pos)
                n = 0 if readers[i] is None else readers[i](data, pos)
                if n < 0:
                    raise PlyError(f"{path}: element {el.name!r} row {row}: negative list length {n}")
                pos += size[i] + n * item[i]
            if pos > end:
                raise _truncated(path, el, row)
    except (struct.error, IndexError):
        raise _truncated(path, el, row) from None
    buf, at = np.frombuffer(data, np.uint8), np.array(starts, np.int64).reshape(el.count, len(el.props))
    table = Table()
    for i, p in enumerate(el.props):
        first = _gather(buf, at[:, i], size[i], order + (p.count or p.type))
        if p.count is None:
            table.scalars.setdefault(p.name, first)
            continue
        n = first.astype(np.int64)
        k = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
        table.lists.setdefault(p.name, (n, _gather(buf, np.repeat(at[:, i] + size[i], n) + k * item[i], item[i],
                                                   order + p.type)))
    return table, pos


def _count_reader(code: str):
    """``read(data, offset)`` -> a list length of numpy type ``code`` (bytes indexing for uchar: fastest)."""
    if code[1:] == "u1":
        return operator.getitem
    unpack = struct.Struct(code[0] + _STRUCT[code[1:]]).unpack_from
    return lambda data, offset: unpack(data, offset)[0]


def _gather(buf: np.ndarray, offsets: np.ndarray, size: int, dtype: str) -> np.ndarray:
    """The values of type ``dtype`` (``size`` bytes) at byte ``offsets`` of ``buf``."""
    return buf[offsets[:, None] + np.arange(size)].view(dtype).ravel()


def _ascii_element(path: Path, nums: np.ndarray, pos: int, el: Element, _order) -> tuple[Table, int]:
    left = len(nums) - pos
    if el.count * len(el.props) > left:
        raise PlyError(f"{path}: element {el.name!r} declares {el.count} rows of at least {len(el.props)} "
                       f"numbers, more than the {left} numbers of data left")
    if el.count == 0:
        return Table(), pos
    lengths, end = {}, pos
    for i, p in enumerate(el.props):
        if p.count is not None:
            lengths[i] = _length(path, el, 0, nums, end)
            end += lengths[i]
        end += 1
    width = end - pos
    if el.count * width <= left:
        # Fast path: every row's lists as long as row 0's.
        block = nums[pos:pos + el.count * width].reshape(el.count, width)
        table, col = Table(), 0
        for i, p in enumerate(el.props):
            if p.count is None:
                table.scalars.setdefault(p.name, block[:, col].astype(p.type))  # as binary would hold it
                col += 1
                continue
            if not (block[:, col] == lengths[i]).all():
                break
            table.lists.setdefault(p.name, (np.full(el.count, lengths[i], np.int64),
                                            block[:, col + 1:col + 1 + lengths[i]].reshape(-1)))
            col += 1 + lengths[i]
        else:
            return table, pos + el.count * width
    values: list[list] = [[] for _ in el.props]
    counts: list[list[int]] = [[] for _ in el.props]
    for row in range(el.count):
        for i, p in enumerate(el.props):
            if pos >= len(nums):
                raise _truncated(path, el, row)
            if p.count is None:
                values[i].append(nums[pos])
                pos += 1
                continue
            n = _length(path, el, row, nums, pos)
            if pos + 1 + n > len(nums):
                raise _truncated(path, el, row)
            values[i].append(nums[pos + 1:pos + 1 + n])
            counts[i].append(n)
            pos += 1 + n
    table = Table()
    for i, p in enumerate(el.props):
        if p.count is None:
            table.scalars.setdefault(p.name, np.array(values[i], np.float64).astype(p.type))
        else:
            table.lists.setdefault(p.name, (np.array(counts[i], np.int64),
                                            np.concatenate(values[i]) if values[i] else np.zeros(0)))
    return table, pos


def _length(path: Path, el: Element, row: int, nums: np.ndarray, pos: int) -> int:
    """A list's length in ASCII data: a count no longer than the numbers left."""
    if pos >= len(nums):
        raise _truncated(path, el, row)
    n = nums[pos]
    if not (0 <= n <= len(nums) - pos - 1 and n == np.floor(n)):
        raise (_truncated(path, el, row) if n == np.floor(n) and n > 0
               else PlyError(f"{path}: element {el.name!r} row {row}: list length {n:g} is not a count"))
    return int(n)


def _fan(path: Path, lengths: np.ndarray, flat: np.ndarray, vertices: int) -> np.ndarray:
    """(T, 3) int64 triangles of polygons given as lengths and flat vertex indices: fans (0, i, i+1)."""
    if flat.dtype.kind == "f" and not (flat == np.floor(flat)).all():
        k = int(np.argmax(flat != np.floor(flat)))
        raise PlyError(f"{path}: face vertex index {flat[k]:g} is not an integer")
    short = lengths < 3
    if short.any():
        k = int(np.argmax(short))
        raise PlyError(f"{path}: face {k} has {lengths[k]} vertex indices: contains point or line primitives, "
                       "only triangles are supported")
    bad = (flat < 0) | (flat >= vertices)
    if bad.any():
        k = int(np.argmax(bad))
        f = int(np.searchsorted(np.cumsum(lengths), k, side="right"))
        raise PlyError(f"{path}: face {f}: vertex index {flat[k]:g} out of range (the file has {vertices} "
                       "vertices)")
    flat = flat.astype(np.int64)
    starts = np.cumsum(lengths) - lengths
    per_face = lengths - 2
    face = np.repeat(np.arange(len(lengths)), per_face)
    i = np.arange(len(face)) - np.repeat(np.cumsum(per_face) - per_face, per_face) + 1
    first = starts[face]
    return np.stack([flat[first], flat[first + i], flat[first + i + 1]], 1)


def _join(positions, normals, uvs, triangles):
    """Only the vertices the triangles use, identical ones (every attribute) joined, in file order:
    what Assimp (JoinIdenticalVertices, which skips unused vertices) made of a PLY, so that
    generated normals are shared across a seam exactly as before (issue #24 item 14)."""
    attrs = np.ascontiguousarray(np.concatenate([a for a in (positions, normals, uvs) if a is not None], 1))
    canon = _identical(attrs)
    mask = np.zeros(len(positions), bool)
    mask[triangles.ravel()] = True
    used = np.flatnonzero(mask)  # file order
    groups, first = np.unique(canon[used], return_index=True)
    order = np.argsort(first, kind="stable")  # each group where its first used vertex stands
    remap = np.empty(len(groups) and int(groups[-1]) + 1, np.int64)
    remap[groups[order]] = np.arange(len(groups))
    rows = used[first[order]]
    return (positions[rows], None if normals is None else normals[rows], None if uvs is None else uvs[rows],
            remap[canon[triangles]])


def _identical(attrs: np.ndarray) -> np.ndarray:
    """A group id per row, equal for bitwise-identical rows: a 64-bit hash of the row's bits
    sorted (a fifth of the time sorting the rows takes), checked exactly; rows sorted if two differ."""
    bits = attrs.view(np.uint64)
    h = np.zeros(len(bits), np.uint64)
    for column in bits.T:
        h = (h ^ column) * np.uint64(0x9E3779B97F4A7C15)  # wraps modulo 2^64
    _, rep, canon = np.unique(h, return_index=True, return_inverse=True)
    canon = canon.ravel()
    if (bits[rep[canon]] == bits).all():
        return canon
    return np.unique(attrs.view(np.dtype((np.void, attrs.shape[1] * 8))).ravel(), return_inverse=True)[1].ravel()

"""mcpt's own PLY reader (issue #24 item 14): every encoding, every class of first data byte, round
trips against files written here, parity with what Assimp made of the files it read, and errors."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from mcpt.shapes.assimp_file import read_assimp
from mcpt.shapes.mesh import MeshError, load_mesh, read_geometry
from mcpt.shapes.ply import TYPES, PlyError, read_ply

ENCODINGS = ("ascii", "binary_little_endian", "binary_big_endian")
_STRUCT = {"i1": "b", "u1": "B", "i2": "h", "u2": "H", "i4": "i", "u4": "I", "f4": "f", "f8": "d"}
QUAD_FACES = [[0, 1, 2, 3]]


def _ascii(value, code: str) -> str:
    return repr(float(value)) if code[0] == "f" else str(int(value))


def write_ply(path: Path, fmt: str, elements, *, header_extra: str = "", newline: str = "\n") -> Path:
    """A reference writer: ``elements`` = [(name, props, rows)]; a prop is ("float", "x") or
    ("list", "uchar", "int", "vertex_indices"); a row holds one value (or a list) per prop."""
    head = ["ply", f"format {fmt} 1.0", "comment written by tests/test_ply.py", "obj_info whatever"]
    head += [header_extra] if header_extra else []
    body = bytearray()
    order = "<" if fmt == "binary_little_endian" else ">"
    for name, props, rows in elements:
        head.append(f"element {name} {len(rows)}")
        head += [f"property {' '.join(p)}" for p in props]
        for row in rows:
            words = []
            for p, value in zip(props, row):
                if p[0] == "list":
                    count, code = TYPES[p[1]], TYPES[p[2]]
                    items = [(count, len(value))] + [(code, v) for v in value]
                else:
                    items = [(TYPES[p[0]], value)]
                for code, v in items:
                    if fmt == "ascii":
                        words.append(_ascii(v, code))
                    else:
                        body += struct.pack(order + _STRUCT[code], v)
            if fmt == "ascii":
                body += (" ".join(words) + newline).encode()
    head.append("end_header")
    path.write_bytes((newline.join(head) + newline).encode() + bytes(body))
    return path


def mesh_elements(positions, faces, *, xyz="float", index="int", count="uchar", normals=None, uvs=None,
                  uv_names=("u", "v")):
    props = [(xyz, c) for c in "xyz"]
    rows = [list(p) for p in positions]
    if normals is not None:
        props += [("float", c) for c in ("nx", "ny", "nz")]
        rows = [r + list(n) for r, n in zip(rows, normals)]
    if uvs is not None:
        props += [("float", c) for c in uv_names]
        rows = [r + list(t) for r, t in zip(rows, uvs)]
    return [("vertex", props, rows), ("face", [("list", count, index, "vertex_indices")], [[f] for f in faces])]


def f32(a) -> np.ndarray:
    return np.asarray(a, np.float32).astype(np.float64)


def first_x(fmt: str, byte: int) -> float:
    """A float32 x whose first byte in the file is ``byte`` (after 0x33 0x1e 0xc0, as in the issue)."""
    raw = bytes([byte, 0x33, 0x1E, 0xC0]) if fmt == "binary_little_endian" else bytes([byte, 0x33, 0x1E, 0x00])
    return struct.unpack("<f" if fmt == "binary_little_endian" else ">f", raw)[0]


BYTE_CLASSES = [0x09, 0x0A, 0x0B, 0x0C, 0x0D, 0x20, *b"0159", *b"AZaz", 0x00, 0xFF]


@pytest.mark.parametrize("fmt", ENCODINGS[1:])
@pytest.mark.parametrize("byte", BYTE_CLASSES, ids=lambda b: f"0x{b:02x}")
def test_binary_data_starts_right_after_the_header_whatever_its_first_byte(tmp_path, fmt, byte):
    positions = [[first_x(fmt, byte), -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]
    path = write_ply(tmp_path / "q.ply", fmt, mesh_elements(positions, QUAD_FACES))
    assert path.read_bytes().split(b"end_header\n", 1)[1][0] == byte
    part = read_geometry(path).parts[0]  # through the dispatch: Assimp failed for 0x09-0x0d, 0x20
    np.testing.assert_array_equal(part.vertices, f32(positions))
    np.testing.assert_array_equal(part.indices, [[0, 1, 2], [0, 2, 3]])


@pytest.mark.parametrize("byte", BYTE_CLASSES, ids=lambda b: f"0x{b:02x}")
def test_ascii_data_whatever_its_first_byte(tmp_path, byte):
    path = write_ply(tmp_path / "q.ply", "ascii", mesh_elements([[0, 0, 0], [7, 0, 0], [0, 7, 0]], [[0, 1, 2]]))
    head, body = path.read_bytes().split(b"end_header\n", 1)
    lead = bytes([byte])
    path.write_bytes(head + b"end_header\n" + (lead + body[1:] if lead.isdigit() else lead + body))
    if lead.isspace() or lead.isdigit():
        part = read_ply(path).parts[0]
        expect = [[float(lead) if lead.isdigit() else 0.0, 0, 0], [7, 0, 0], [0, 7, 0]]
        np.testing.assert_array_equal(part.vertices, expect)
    else:
        with pytest.raises(PlyError, match=r"q\.ply:\d+: .* is not a number") as info:
            read_ply(path)
        assert "\n" not in str(info.value)


def test_the_issue_quad_loads_like_its_ascii_twin(tmp_path):
    # issue #24 item 14: first x -2.4718659 = bytes 0d 33 1e c0; Assimp failed with exit 2.
    positions = [[-2.4718659, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]
    elements = mesh_elements(positions, QUAD_FACES)
    binary = write_ply(tmp_path / "quad_bin.ply", "binary_little_endian", elements)
    ascii_ = write_ply(tmp_path / "quad_ascii.ply", "ascii", elements)
    assert binary.read_bytes().split(b"end_header\n", 1)[1][:4] == bytes.fromhex("0d331ec0")
    a, b = load_mesh(ascii_), load_mesh(binary)
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.faces, b.faces)
    np.testing.assert_array_equal(b.vertices, f32(positions))
    assert b.num_triangles == 2


@pytest.mark.parametrize("fmt", ENCODINGS)
@pytest.mark.parametrize("newline", ["\n", "\r\n"], ids=["lf", "crlf"])
def test_round_trip_every_attribute_type_and_polygon(tmp_path, fmt, newline):
    rng = np.random.default_rng(7)
    positions = rng.integers(-100, 100, (7, 3)).tolist()  # integral: exact in every integer type
    normals = f32(rng.normal(size=(7, 3)))
    uvs = f32(rng.random((7, 2)))
    faces = [[0, 1, 2], [2, 1, 3, 4], [4, 3, 5, 6, 0], [6, 5, 2]]  # triangles, a quad, a pentagon
    for xyz in ("char", "short", "int", "float", "double", "int32", "float64"):
        for index, count in (("int", "uchar"), ("uint", "int"), ("ushort", "uint8"), ("uchar", "ushort"),
                             ("char", "uint")):
            for uv_names in (("u", "v"), ("s", "t"), ("texture_u", "texture_v")):
                el = mesh_elements(positions, faces, xyz=xyz, index=index, count=count, normals=normals,
                                   uvs=uvs, uv_names=uv_names)
                # Unknown elements and properties, lists included, before and between the known ones.
                el[0][1].insert(0, ("list", "uchar", "double", "junk"))
                for r in el[0][2]:
                    r.insert(0, [1.5, -2.0][: len(r) % 3])
                el[0][1].append(("uchar", "red"))
                for r in el[0][2]:
                    r.append(200)
                el.insert(0, ("material", [("float", "k"), ("list", "int", "short", "ids")], [[0.5, [1, 2]], [1, []]]))
                el.insert(2, ("edge", [("int", "a"), ("int", "b")], [[0, 1]]))
                path = write_ply(tmp_path / "m.ply", fmt, el, newline=newline)
                part = read_ply(path, need_normals=True).parts[0]
                np.testing.assert_array_equal(part.vertices, positions)
                np.testing.assert_array_equal(part.normals, normals)
                np.testing.assert_array_equal(part.uvs, uvs)
                fans = [[f[0], f[i], f[i + 1]] for f in faces for i in range(1, len(f) - 1)]
                np.testing.assert_array_equal(part.indices, fans)


@pytest.mark.parametrize("fmt", ENCODINGS)
def test_vertex_index_name_and_unused_and_repeated_vertices(tmp_path, fmt):
    # Assimp kept only the vertices faces use and joined identical ones, in file order: kept.
    positions = [[9, 9, 9], [0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0]]
    el = mesh_elements(positions, [[1, 2, 3], [4, 5, 3]])
    el[1][1][0] = ("list", "uchar", "int", "vertex_index")
    part = read_ply(write_ply(tmp_path / "m.ply", fmt, el)).parts[0]
    np.testing.assert_array_equal(part.vertices, [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    np.testing.assert_array_equal(part.indices, [[0, 1, 2], [1, 3, 2]])
    assert part.normals is None and part.uvs is None


@pytest.mark.parametrize("with_normals, with_uvs", [(False, False), (True, False), (False, True), (True, True)])
def test_same_mesh_as_assimp_made_of_it(tmp_path, with_normals, with_uvs):
    rng = np.random.default_rng(3)
    positions = f32(rng.random((40, 3)) * 10 - 5)
    positions[30:] = positions[:10]  # exact repeats (a seam), joined as Assimp joined them
    normals = f32(rng.normal(size=(40, 3))) if with_normals else None
    if normals is not None:
        normals[30:] = normals[:10]
    uvs = f32(rng.random((40, 2))) if with_uvs else None
    faces = [list(rng.choice(38, 3, replace=False)) for _ in range(50)]  # 38, 39 unused
    path = write_ply(tmp_path / "r.ply", "ascii", mesh_elements(positions, faces, normals=normals, uvs=uvs))
    ours, theirs = read_ply(path, need_normals=True), read_assimp(path, need_normals=True)
    a, b = ours.parts[0], theirs.parts[0]
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.indices, np.asarray(b.indices).reshape(-1, 3))
    for got, want in ((a.normals, b.normals), (a.uvs, b.uvs)):
        assert (got is None) == (want is None)
        if got is not None:
            np.testing.assert_array_equal(got, want)
    assert len(ours.materials) == 1 and ours.materials[0].kd is None


def test_dispatch_sends_ply_to_mcpt_and_other_formats_to_assimp(tmp_path, monkeypatch):
    from mcpt.shapes import assimp_file, mesh

    calls = []
    monkeypatch.setattr(mesh, "read_assimp", lambda *a, **k: calls.append(a) or assimp_file.read_assimp(*a, **k))
    ply = write_ply(tmp_path / "t.PLY", "binary_big_endian", mesh_elements([[0, 0, 0], [1, 0, 0], [0, 1, 0]],
                                                                             [[0, 1, 2]]))
    assert read_geometry(ply).parts[0].vertices.shape == (3, 3) and calls == []
    obj = tmp_path / "t.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    read_geometry(obj)
    assert len(calls) == 1


HEADER = "ply\nformat {fmt} 1.0\nelement vertex {v}\nproperty float x\nproperty float y\nproperty float z\n" \
         "element face {f}\nproperty list uchar int vertex_indices\nend_header\n"
TRI = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)


@pytest.mark.parametrize(
    "name, data, match",
    [
        ("notply.ply", b"hello world\n", "not a PLY file"),
        ("nohead.ply", b"ply\nformat ascii 1.0\nelement vertex 3\n", "no end_header"),
        ("fmt.ply", HEADER.format(fmt="binary_middle_endian", v=3, f=1).encode(), r":2: unknown PLY format"),
        ("nofmt.ply", b"ply\nelement vertex 0\nend_header\n", "no format line"),
        ("type.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty real x\nend_header\n",
         r":4: unknown property type 'real'"),
        ("count.ply", b"ply\nformat ascii 1.0\nelement vertex many\nend_header\n", r":3: expected 'element"),
        ("orphan.ply", b"ply\nformat ascii 1.0\nproperty float x\nend_header\n", r":3: a property before"),
        ("listf.ply", b"ply\nformat ascii 1.0\nelement f 1\nproperty list float int i\nend_header\n",
         "an integer type is needed"),
        ("noxyz.ply", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n",
         "no 'vertex' element with scalar x, y and z"),
        ("noface.ply", HEADER.format(fmt="binary_little_endian", v=3, f=0).encode() + TRI, "contains no triangles"),
        ("trunc.ply", HEADER.format(fmt="binary_little_endian", v=3, f=1).encode() + TRI + bytes([3, 0, 0, 0, 0, 1]),
         r"truncated: element 'face' row 0 of 1"),
        ("huge.ply", HEADER.format(fmt="binary_little_endian", v=2**40, f=1).encode() + TRI,
         r"element 'vertex' declares 1099511627776 rows of at least 12 bytes, more than the 36 bytes"),
        ("hugeascii.ply", HEADER.format(fmt="ascii", v=2**40, f=1).encode() + b"0 0 0\n",
         r"element 'vertex' declares 1099511627776 rows of at least 3 numbers, more than the 3 numbers"),
        ("hugelist.ply", HEADER.format(fmt="binary_little_endian", v=3, f=2).encode() + TRI + bytes([255]) * 8,
         r"truncated: element 'face'"),
        ("range.ply", HEADER.format(fmt="binary_little_endian", v=3, f=1).encode() + TRI
         + bytes([3]) + struct.pack("<3i", 0, 1, 3), r"face 0: vertex index 3 out of range \(the file has 3"),
        ("negative.ply", HEADER.format(fmt="binary_big_endian", v=3, f=2).encode() + struct.pack(">9f", *range(9))
         + bytes([3]) + struct.pack(">3i", 0, 1, 2) + bytes([3]) + struct.pack(">3i", 0, -1, 2),
         r"face 1: vertex index -1 out of range"),
        ("asciirange.ply", HEADER.format(fmt="ascii", v=3, f=1).encode() + b"0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
         "face 0: vertex index 7 out of range"),
        ("frac.ply", HEADER.format(fmt="ascii", v=3, f=1).encode() + b"0 0 0\n1 0 0\n0 1 0\n3 0 1 1.5\n",
         "face vertex index 1.5 is not an integer"),
        ("line.ply", HEADER.format(fmt="ascii", v=3, f=1).encode() + b"0 0 0\n1 0 0\n0 1 0\n2 0 1\n",
         "face 0 has 2 vertex indices: contains point or line primitives"),
        ("neglen.ply", HEADER.replace("list uchar", "list int").format(fmt="binary_little_endian", v=3, f=2).encode()
         + TRI + struct.pack("<4i", 3, 0, 1, 2) + struct.pack("<i", -3), "row 1: negative list length -3"),
        ("badlen.ply", HEADER.format(fmt="ascii", v=3, f=1).encode() + b"0 0 0\n1 0 0\n0 1 0\n-3 0 1 2\n",
         "list length -3 is not a count"),
        ("asciitrunc.ply", HEADER.format(fmt="ascii", v=3, f=2).encode() + b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0\n",
         "truncated"),
        ("word.ply", HEADER.format(fmt="ascii", v=3, f=1).encode() + b"0 0 0\n1 0 zero\n0 1 0\n3 0 1 2\n",
         r"word\.ply:11: 'zero' is not a number"),
    ],
)
def test_bad_files_fail_in_one_line_naming_the_file(tmp_path, name, data, match):
    path = tmp_path / name
    path.write_bytes(data)
    with pytest.raises(PlyError, match=match) as info:
        load_mesh(path)
    message = str(info.value)
    assert message.startswith(str(path)) and "\n" not in message
    assert isinstance(info.value, MeshError)


def test_unreadable_file(tmp_path):
    with pytest.raises(PlyError, match="cannot read"):
        read_ply(tmp_path)


def test_a_comment_may_hold_any_byte(tmp_path):
    path = write_ply(tmp_path / "c.ply", "binary_little_endian", mesh_elements([[0, 0, 0], [1, 0, 0], [0, 1, 0]],
                                                                               [[0, 1, 2]]))
    data = path.read_bytes().replace(b"comment written", "comment Ünïcødé \xff written".encode(), 1)
    path.write_bytes(data)
    assert read_ply(path).parts[0].vertices.shape == (3, 3)


def test_mitsuba_ply_shape_reads_the_issue_quad(tmp_path):
    from mcpt.scene import load_scene
    from mcpt.shapes.mesh import assemble
    from mcpt.shapes.sources import source_of

    positions = [[-2.4718659, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]
    write_ply(tmp_path / "q.ply", "binary_little_endian", mesh_elements(positions, QUAD_FACES))
    camera = Path(__file__).parent / "data" / "mitsuba" / "camera.xml"
    xml = tmp_path / "s.xml"
    xml.write_text(f'<scene version="3.0.0">\n<include filename="{camera}"/>\n'
                   '<shape type="ply"><string name="filename" value="q.ply"/></shape>\n</scene>\n')
    spec = load_scene(xml).meshes[0]
    mesh = assemble(read_geometry(source_of(spec)), spec.transform.matrix())
    np.testing.assert_allclose(mesh.vertices, f32(positions) @ spec.transform.matrix()[:3, :3].T
                               + spec.transform.matrix()[:3, 3])
    assert mesh.num_triangles == 2

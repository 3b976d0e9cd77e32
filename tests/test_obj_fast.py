"""The numpy OBJ reader (mcpt/shapes/obj_fast.py) gives what Assimp's import gives, bit for bit, or
steps aside (None) so that Assimp reads the file (issue #23)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mcpt.shapes import assimp_file, obj_fast, obj_join
from mcpt.shapes.obj_fast import read_obj_fast

from .conftest import CORNELL

ROOT = Path(__file__).resolve().parents[1]
# The repository's own OBJs: shipped scenes and tests/data (copies of ../shared models and
# reference scenes; tests read nothing outside the repository, tests/test_structure.py).
MODELS = sorted({*ROOT.glob("scenes/**/*.obj"), *ROOT.glob("tests/data/**/*.obj")})


def assimp_only(path: Path, need_normals: bool, monkeypatch):
    """What read_assimp gives with the fast reader switched off."""
    with monkeypatch.context() as m:
        m.setattr(assimp_file, "read_obj_fast", lambda *a, **k: None)
        return assimp_file.read_assimp(path, need_normals=need_normals)


def assert_same(fast, ref) -> None:
    assert [m for m in fast.materials] == [m for m in ref.materials]
    assert len(fast.parts) == len(ref.parts)
    for a, b in zip(fast.parts, ref.parts):
        assert (a.label, a.material) == (b.label, b.material)
        for field in ("vertices", "indices", "normals", "uvs"):
            x, y = getattr(a, field), getattr(b, field)
            assert (x is None) == (y is None), field
            if x is not None:
                assert x.shape == y.shape and x.dtype == y.dtype, field
                assert x.tobytes() == y.tobytes(), field  # bit for bit, -0.0 included


@pytest.mark.parametrize("path", MODELS, ids=lambda p: f"{p.parent.name}/{p.name}")
@pytest.mark.parametrize("need_normals", [False, True])
def test_models_match_assimp(path, need_normals, monkeypatch):
    fast = read_obj_fast(path, path.read_bytes(), need_normals=need_normals)
    if fast is not None:
        assert_same(fast, assimp_only(path, need_normals, monkeypatch))


def test_common_models_take_the_fast_path():
    """Not vacuous: the Cornell box, spot (v/vt), the teapot (-0.0 beside 0.0) and suzanne
    (quads, v//vn) are read here."""
    teapot = [ROOT / "tests/data/models" / m for m in ("teapot.obj", "suzanne.obj")]
    for path in [*CORNELL.glob("*.obj"), ROOT / "scenes/models/spot/spot_triangulated.obj",
                 ROOT / "scenes/models/icosphere.obj", *teapot]:
        assert read_obj_fast(path, path.read_bytes()) is not None, path


NUMBERS = ["1.3", "-0.5", "0.5", "1.", "+2.25", "123456789.123456789012345678", "0.1234567890123456789",
           "-9.25427e-05", "3.5E+2", "7e-45", "1.17549435e-38", "2.5e12", "16777217", "0.30000001192092896",
           "-1.000000059604644775390625", "4.999999", "10000000000000"]


def test_numbers_parse_as_assimp_parses_them(tmp_path, monkeypatch):
    """fast_atoreal_move<float> is not a correctly rounded parse: its float32 sums and powf
    exponents are reproduced (every token here lands on a different vertex row). Coordinates past
    ~1.6e13 are left to Assimp by the join check (obj_join._near_pairs: 2^60 of its steps), so stop there."""
    rows = [f"v {x} {i}.25 {-i}" for i, x in enumerate(NUMBERS)]
    rows += [f"v 1 {i}e-{i} {i}.5" for i in range(1, 46)] + [f"v 2 3.{i}e{i} {i}.75" for i in range(0, 13)]
    n = len(rows)
    faces = [f"f {i + 1} {(i + 1) % n + 1} {(i + 2) % n + 1}" for i in range(n)]
    path = tmp_path / "numbers.obj"
    path.write_text("\n".join(["# numbers", *rows, "s off", *faces]) + "\n")
    fast = read_obj_fast(path, path.read_bytes())
    assert fast is not None
    assert_same(fast, assimp_only(path, False, monkeypatch))


def test_seams_and_shared_corners_join_as_assimp(tmp_path, monkeypatch):
    """A position used with two UVs (a seam) stays two vertices, repeated rows of the tables
    join, vertex order is first use, normals follow their corner."""
    text = """v 0 0 0
v 1 0 0
v 0 1 0
v 1 1 0
v 0 0 0
vt 0 0
vt 1 0
vt 0 1
vt 1 1
vt 0.5 0.5
vn 0 0 1
vn 0 0 1
vn 0 0.6 0.8
vn 0 2 0
f 1/4/4 2/2/4 3/3/4
f 1/1/1 2/2/1 3/3/2
f 2/2/2 4/4/3 3/3/1
f 5/5/1 2/2/1 4/4/3
f 5/1/2 2/2/1 3/3/2
"""
    path = tmp_path / "seams.obj"
    path.write_text(text)
    for need in (False, True):
        fast = read_obj_fast(path, path.read_bytes(), need_normals=need)
        assert fast is not None
        assert_same(fast, assimp_only(path, need, monkeypatch))
    # Equal rows join (vn 1 = vn 2, v 5 = v 1): 1/4/4, 2/2/4, 3/3/4 (a normal of length 2, kept
    # as the file gives it), then 1/1/1, 2/2/1, 3/3/2, 4/4/3 and the seam corner 5/5/1 (the
    # position of v 1 with another UV) are the eight vertices.
    assert len(fast.parts[0].vertices) == 8


@pytest.mark.parametrize("text", [
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 2 2 0\nf 1 2 4 5 3\n",  # a pentagon: Assimp's ear cutting
    "v 0 0 0\nv 1 0 0\nv 1 1e-9 0\nv 0 1 0\nf 1 2 3 4\n",      # a quad with a straight corner
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n",          # materials
    "v 0 0 0\nv 1 0 0\nv 0 1 0\ng part\nf 1 2 3\n",              # groups
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n",                   # relative indices
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0.000001 0 0\nf 1 2 3\nf 4 2 3\n",  # within Assimp's join epsilon
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1/1 2/1 3/1\nvt 0 0\n",  # mixed face forms
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",                      # out of range (Assimp names the line)
    "v 0 0 0\nv 1,5 0 0\nv 0 1 0\nf 1 2 3\n",                    # a comma
    "v 0 0 0\nv .5 0 0\nv 0 1 0\nv 0 2 0\nf 1 2 3\n",           # ".5": Assimp drops the vertex
    "v 0 0 0\nv 1/2 0\nv 0 1 0\nf 1 2 3\n",                    # "1/2": one number to Assimp
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 02 3\n",                   # "02": read twice by Assimp
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1/1 2/1 3/1\nvt 0 0\n",  # vt after the faces
])
def test_outside_the_subset_is_left_to_assimp(tmp_path, text):
    path = tmp_path / "other.obj"
    path.write_text(text)
    assert read_obj_fast(path, path.read_bytes()) is None


@pytest.mark.parametrize("first", ["-0", "0"])
def test_minus_zero_joins_zero_keeping_the_first_corners_bits(tmp_path, monkeypatch, first):
    """Assimp joins -0.0 and 0.0 (libstdc++ hashes both to 0) and keeps the bits of the corner
    that uses the value first (teapot.obj: 3 325 distinct rows, 3 241 vertices)."""
    other = "0" if first == "-0" else "-0"
    path = tmp_path / "zeros.obj"
    path.write_text(f"v 1 0 0\nv 0 1 0\nv {first} 0 0\nv {other} 0 0\nf 3 1 2\nf 4 2 1\n")
    fast = read_obj_fast(path, path.read_bytes())
    assert fast is not None and len(fast.parts[0].vertices) == 3
    assert np.signbit(fast.parts[0].vertices[0, 0]) == (first == "-0")
    assert_same(fast, assimp_only(path, False, monkeypatch))


def test_a_tiny_near_pair_goes_to_assimp_but_a_far_one_does_not(tmp_path):
    """The join check: 2e-5 apart is outside Assimp's 1e-5 tolerance (fast path), 5e-6 inside."""
    for gap, fast in (("0.00002", True), ("0.000005", False)):
        path = tmp_path / "pair.obj"
        path.write_text(f"v 0 0 0\nv 1 0 0\nv 0 1 0\nv {gap} 0 0\nf 1 2 3\nf 4 3 2\n")
        assert (read_obj_fast(path, path.read_bytes()) is not None) is fast


@pytest.mark.parametrize("dims", [2, 3])
def test_the_join_check_finds_every_near_pair(dims):
    """_near_pairs (four shifted grids) against brute force: every table holding two rows within
    JOIN_EPSILON is reported, in every direction and at every offset against the grids' cells;
    tables whose rows are all farther apart than a few cells are not."""
    rng = np.random.default_rng(7)
    eps = obj_join.JOIN_EPSILON
    for trial in range(300):
        base = rng.uniform(-2.0, 2.0, (40, dims)).astype(np.float32)
        if trial % 3:
            # A second row within eps (or just past it) of a first one, in a random direction.
            d = rng.normal(size=dims)
            d *= rng.uniform(0.05, 1.3) * eps / np.linalg.norm(d)
            base[1] = (base[0].astype(np.float64) + d).astype(np.float32)
        rows = np.unique(base, axis=0)
        diff = rows[:, None, :].astype(np.float64) - rows[None, :, :]
        dist2 = np.einsum("ijk,ijk->ij", diff, diff) + np.eye(len(rows))
        if (dist2 <= eps**2).any():
            assert obj_join._near_pairs(rows), rows
        elif dist2.min() > (10 * eps) ** 2:
            assert not obj_join._near_pairs(rows), rows


def _random_obj(rng: np.random.Generator) -> str:
    """A small OBJ in the subset, with numbers written many ways (digits, signs, exponents, CRLF)."""
    def num() -> str:
        x = rng.normal() * 10.0 ** rng.integers(-6, 5)
        style = rng.integers(4)
        if style == 0:
            return f"{x:.{rng.integers(0, 12)}f}"
        if style == 1:
            return f"{x:.{rng.integers(1, 9)}e}"
        if style == 2:
            return repr(float(np.float32(x)))
        return f"{x:+.{rng.integers(1, 17)}g}"
    nv, nt = int(rng.integers(3, 40)), int(rng.integers(1, 10))
    lines = [f"v {num()} {num()} {num()}" for _ in range(nv)] + [f"vt {num()} {num()}" for _ in range(nt)]
    form = rng.integers(2)
    for _ in range(int(rng.integers(1, 30))):
        v, t = rng.integers(1, nv + 1, 3), rng.integers(1, nt + 1, 3)
        lines.append("f " + " ".join(f"{a}/{b}" if form else f"{a}" for a, b in zip(v, t)))
    return ("\r\n" if rng.integers(2) else "\n").join(lines) + "\n"


@pytest.mark.parametrize("block", [40, 997])
def test_files_read_in_blocks_match_assimp(tmp_path, monkeypatch, block):
    """Blocks of whole lines (obj_fast.BLOCK_BYTES) cut between a file's v and f lines, inside
    either, before the first face: the same result."""
    monkeypatch.setattr(obj_fast, "BLOCK_BYTES", block)
    rng = np.random.default_rng(block)
    paths = [ROOT / "scenes/models/spot/spot_triangulated.obj", *CORNELL.glob("*.obj")]
    for i in range(20):
        paths.append(tmp_path / f"b{i}.obj")
        paths[-1].write_bytes(_random_obj(rng).encode())
    for path in paths:
        fast = read_obj_fast(path, path.read_bytes())
        if fast is not None:
            assert_same(fast, assimp_only(path, False, monkeypatch))


@pytest.mark.parametrize("faces, taken", [
    ("f 1 2 3\nf\t2 3 4\nf 1  2 4 \nf 4 3 2 1\nf 10 11 12\n", True),  # tabs, runs of spaces, a quad
    ("f 1 2 3\r\nf 2 3 4\r\nf 4 3 2 1\r\n", True),                    # CRLF
    ("f 1 2 3\nf 1 02 3\n", False),                                  # a leading zero: Assimp's quirk
    ("f 1 2 3\nf 1 0 3\n", False),                                   # index 0
    ("f 1 2 3\nf 1 1f 3\n", False),                                  # an f inside a line ("10" if read as 0)
    ("f 1 2 3\nf 1 2\n", False),                                     # two corners
    ("f 1 2 3\nf 1 2 3 4 5\n", False),                               # a pentagon
    ("f 1 2 3\nf 1 2 3 # c\n", False),                               # a comment after a face
    ("f 1 2 3\nf 1 2 99999999999999999999\n", False),                # past 18 digits
])
def test_blocks_of_v_faces_match_assimp(tmp_path, monkeypatch, faces, taken):
    """Blocks made only of ``v``-form face lines are read by numpy's integer parser in one call
    (obj_fast._v_faces): the same result as the general path and Assimp, or left to Assimp where
    the general path leaves them."""
    monkeypatch.setattr(obj_fast, "BLOCK_BYTES", 8)  # a block a line: the faces' blocks hold faces only
    used = []
    real = obj_fast._v_faces
    monkeypatch.setattr(obj_fast, "_v_faces", lambda *a: used.append(real(*a)) or used[-1])
    path = tmp_path / "faces.obj"
    pts = np.random.default_rng(5).normal(size=(12, 3)).round(3)
    verts = "".join(f"v {x} {y} {z}\n" for x, y, z in pts)
    path.write_bytes((verts + faces).encode())
    fast = read_obj_fast(path, path.read_bytes())
    assert (fast is not None) is taken
    if taken:
        assert used and all(u is not None for u in used)
        assert_same(fast, assimp_only(path, False, monkeypatch))
    else:
        assert None in used  # the fast path declined the bad line's block itself


def test_quads_are_fanned_from_their_concave_corner_as_assimp(tmp_path, monkeypatch):
    """Convex quads fan from corner 0; a concave (dart-shaped) quad from its reflex corner,
    wherever it sits in the face; triangles between them stay as they are."""
    v = ["v 0 0 0", "v 2 0 0", "v 2 2 0", "v 0 2 0", "v 0.5 0.5 0", "v 3 1 0.5"]
    darts = ["f 1 2 5 4", "f 4 1 2 5", "f 5 4 1 2", "f 2 5 4 1"]  # reflex corner 5 at 2, 3, 0, 1
    path = tmp_path / "quads.obj"
    path.write_text("\n".join([*v, "f 1 2 3 4", *darts, "f 2 6 3", "f 1 2 6 3"]) + "\n")
    fast = read_obj_fast(path, path.read_bytes())
    assert fast is not None
    assert_same(fast, assimp_only(path, False, monkeypatch))
    tris = fast.parts[0].vertices[fast.parts[0].indices.reshape(-1, 3)]
    assert len(tris) == 13
    assert all((t[0] == [0.5, 0.5, 0]).all() for t in tris[2:10])  # every dart fans from v 5


def test_random_quads_match_assimp(tmp_path, monkeypatch):
    """Quads of random corners (non-planar, concave, convex): Assimp's fan wherever taken."""
    rng = np.random.default_rng(4)
    taken = 0
    for i in range(40):
        pts = rng.normal(size=(8, 3)).round(3)
        faces = [rng.choice(8, 4, replace=False) + 1 for _ in range(6)]
        path = tmp_path / f"q{i}.obj"
        path.write_text("\n".join([f"v {a} {b} {c}" for a, b, c in pts]
                                  + ["f " + " ".join(map(str, f)) for f in faces]) + "\n")
        fast = read_obj_fast(path, path.read_bytes())
        if fast is not None:
            taken += 1
            assert_same(fast, assimp_only(path, False, monkeypatch))
    assert taken > 30


def test_random_files_match_assimp(tmp_path, monkeypatch):
    """200 random files: every one the fast path takes is Assimp's, bit for bit (most are taken)."""
    rng = np.random.default_rng(23)
    taken = 0
    for i in range(200):
        path = tmp_path / f"r{i}.obj"
        path.write_bytes(_random_obj(rng).encode())
        fast = read_obj_fast(path, path.read_bytes())
        if fast is not None:
            taken += 1
            assert_same(fast, assimp_only(path, False, monkeypatch))
    assert taken > 150


def test_a_face_without_corners_goes_to_assimp(tmp_path):
    """The face form is read from the first f line before the blocks are parsed; an f line
    without corners there is outside the subset (it used to raise IndexError)."""
    path = tmp_path / "empty_face.obj"
    path.write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf \nf 1 2 3\n")
    assert read_obj_fast(path, path.read_bytes()) is None


@pytest.mark.parametrize("threads", ["1", "2"])
def test_the_face_form_sees_texture_coordinates_anywhere_before_the_first_face(tmp_path, monkeypatch, threads):
    """"a/b" corners read as v/vt only after a vt line (Assimp's getFace): a vt line at the very
    start, or after a tab, counts; one after the first face does not."""
    monkeypatch.setenv("MCPT_THREADS", threads)
    monkeypatch.setattr(obj_fast, "BLOCK_BYTES", 16)
    v = b"v 0 0 0\nv 1 0 0\nv 0 1 0\n"
    for text, ok in ((b"vt 0 0\n" + v + b"f 1/1 2/1 3/1\n", True),
                     (v + b"vt\t0 0\nf 1/1 2/1 3/1\n", True),
                     (v + b"f 1/1 2/1 3/1\nvt 0 0\n", False)):
        path = tmp_path / "vt.obj"
        path.write_bytes(text)
        fast = read_obj_fast(path, text)
        assert (fast is not None) == ok, text
        if ok:
            assert_same(fast, assimp_only(path, False, monkeypatch))

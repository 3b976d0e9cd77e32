"""Mitsuba 3 XML scenes (issue #19): transforms, cameras, primitives, .serialized, refusals, render."""

from __future__ import annotations

import math
import re
import struct
import subprocess
import sys
import time
import zlib
from pathlib import Path

import numpy as np
import pytest

from mcpt.scene import SceneError, load_scene
from mcpt.scene.mitsuba import scene_data
from mcpt.scene.mitsuba.camera import UNLIMITED_BOUNCES, vfov_deg, x_fov
from mcpt.scene.mitsuba.values import look_at, transform
from mcpt.scene.mitsuba.xmltree import Node, XmlError
from mcpt.shapes import primitives as P
from mcpt.shapes.serialized import SerializedError, read_serialized

DATA = Path(__file__).parent / "data" / "mitsuba"
BENCH = Path(__file__).resolve().parent.parent / "bench" / "scenes-xml"


def write_xml(tmp_path: Path, body: str, name: str = "s.xml", camera: bool = True) -> Path:
    """A scene file in tmp_path: ``body`` inside <scene>, after the shared camera (an include)."""
    inc = f'<include filename="{DATA / "camera.xml"}"/>' if camera else ""
    path = tmp_path / name
    path.write_text(f'<scene version="3.0.0">\n{inc}\n{body}\n</scene>\n')
    return path


def xml_transform(text: str) -> np.ndarray:
    import xml.etree.ElementTree as ET

    def node(e):
        n = Node(e.tag, dict(e.attrib), Path("t.xml"), 1)
        n.children = [node(c) for c in e]
        return n

    return transform(node(ET.fromstring(text)))


# --- transforms ---------------------------------------------------------------------------------

def test_each_operation_left_multiplies_in_file_order():
    m = xml_transform('<transform name="to_world"><scale x="2" y="3" z="4"/>'
                      '<rotate y="1" angle="90"/><translate x="1" y="2" z="3"/></transform>')
    s = np.diag([2.0, 3.0, 4.0, 1.0])
    r = np.array([[0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1]], float)  # Ry(90)
    t = np.eye(4)
    t[:3, 3] = [1, 2, 3]
    np.testing.assert_allclose(m, t @ r @ s, atol=1e-15)
    # (1, 0, 0) is scaled to (2, 0, 0), turned to (0, 0, -2), moved to (1, 2, 1).
    np.testing.assert_allclose(m @ [1, 0, 0, 1], [1, 2, 1, 1], atol=1e-15)


def test_matrix_is_row_major_and_rotate_is_right_handed_about_any_axis():
    m = xml_transform('<transform name="t"><matrix value="1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1"/></transform>')
    np.testing.assert_array_equal(m[:3, 3], [5, 6, 7])
    u = 1 / math.sqrt(3)
    r = xml_transform(f'<transform name="t"><rotate x="{u}" y="{u}" z="{u}" angle="120"/></transform>')
    np.testing.assert_allclose(r @ [1, 0, 0, 1], [0, 1, 0, 1], atol=1e-12)  # x -> y -> z -> x


def test_lookat_columns_are_left_up_forward_origin():
    m = look_at([1, 2, 3], [1, 2, 0], [0, 1, 0])
    np.testing.assert_allclose(m[:3, 2], [0, 0, -1])   # forward
    np.testing.assert_allclose(m[:3, 1], [0, 1, 0])    # up
    np.testing.assert_allclose(m[:3, 0], [-1, 0, 0])   # left = up x forward: the image's left
    np.testing.assert_allclose(m[:3, 3], [1, 2, 3])


# --- camera ------------------------------------------------------------------------------------

# Mitsuba 3.9.1's own mi.parse_fov(props, aspect) for fov 40 (horizontal fov, degrees), run once in
# the peer venv: aspect 2 and aspect 0.5.
MITSUBA_X_FOV = {"x": (40.0, 40.0), "y": (72.10477746477582, 20.628209631236388),
                 "diagonal": (36.0647871891889, 18.490187001430005),
                 "smaller": (72.10477746477582, 40.0), "larger": (40.0, 20.628209631236388)}


@pytest.mark.parametrize("axis", sorted(MITSUBA_X_FOV))
def test_fov_axis_gives_mitsubas_horizontal_fov(tmp_path, axis):
    for aspect, expected in zip((2.0, 0.5), MITSUBA_X_FOV[axis]):
        w, h = (32, 16) if aspect == 2.0 else (16, 32)
        path = write_xml(tmp_path, f'''<sensor type="perspective"><float name="fov" value="40"/>
            <string name="fov_axis" value="{axis}"/><film type="hdrfilm"><integer name="width" value="{w}"/>
            <integer name="height" value="{h}"/><rfilter type="box"/></film></sensor>
            <shape type="sphere"/>''', camera=False)
        vfov = load_scene(path).camera.vfov_deg
        assert vfov == pytest.approx(vfov_deg(expected, aspect), rel=1e-12)
        # and back: the horizontal fov mcpt's image spans is Mitsuba's
        assert 2 * math.degrees(math.atan(math.tan(math.radians(vfov) / 2) * aspect)) == pytest.approx(expected)


def test_focal_length_is_35mm_film_and_defaults_to_50mm():
    from mcpt.scene.mitsuba.values import as_string  # noqa: F401  (the module under test)

    f35 = Node("string", {"name": "focal_length", "value": "35mm"}, Path("t.xml"), 1)
    sensor = Node("sensor", {"type": "perspective"}, Path("t.xml"), 1)
    assert x_fov({"focal_length": f35}, 1.5, sensor) == pytest.approx(54.432223114614956, rel=1e-9)
    assert x_fov({}, 1.5, sensor) == pytest.approx(39.59775270904987, rel=1e-9)  # Mitsuba's values


def test_camera_pose_and_max_depth(tmp_path):
    scene = load_scene(DATA / "small.xml")
    assert scene.camera.position == (0.0, 0.0, 4.0) and scene.camera.look_at == (0.0, 0.0, 3.0)
    assert scene.render.bounces == 3 and scene.render.spp == 8
    path = write_xml(tmp_path, '<integrator type="path"><integer name="max_depth" value="-1"/></integrator>'
                     '<shape type="sphere"/>')
    assert load_scene(path).render.bounces == UNLIMITED_BOUNCES


# --- primitives --------------------------------------------------------------------------------

AREAS = {"rectangle": 4.0, "cube": 24.0, "disk": math.pi, "sphere": 4 * math.pi, "cylinder": 2 * math.pi}


@pytest.mark.parametrize("kind", P.KINDS)
def test_primitive_area_normals_and_distance_to_the_true_surface(kind):
    prim = P.make(kind)
    v = prim.positions[prim.faces]
    cross = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    area = 0.5 * np.linalg.norm(cross, axis=1).sum()
    # Inscribed polygons: never larger, and short by less than 2 x tolerance (module doc).
    assert AREAS[kind] * (1 - 2 * P.TOLERANCE) < area <= AREAS[kind] * (1 + 1e-12)
    np.testing.assert_allclose(np.linalg.norm(prim.normals, axis=1), 1.0, rtol=1e-12)
    # Counter-clockwise seen from where the analytic normal points.
    assert (np.einsum("ij,ij->i", cross, prim.normals[prim.faces].mean(axis=1)) > 0).all()
    if kind in ("sphere", "cylinder", "disk"):
        # The centre of each triangle lies within tolerance x radius of the true surface.
        c = v.mean(axis=1)
        r = {"sphere": np.linalg.norm(c, axis=1), "cylinder": np.linalg.norm(c[:, :2], axis=1),
             "disk": np.ones(len(c))}[kind]
        assert (1 - r).max() <= P.TOLERANCE + 1e-12 and r.max() <= 1 + 1e-12


def test_flip_normals_reverses_winding_and_normals():
    prim = P.sphere()
    f = P.flipped(prim)
    np.testing.assert_array_equal(f.faces, prim.faces[:, [0, 2, 1]])
    np.testing.assert_array_equal(f.normals, -prim.normals)


def test_segments_follow_the_tolerance():
    n = P.segments(1e-3)
    assert 1 - math.cos(math.pi / n) <= 1e-3 < 1 - math.cos(math.pi / (n - 1))


# --- .serialized -------------------------------------------------------------------------------

def serialized_shape(pos, faces, normals=None, uvs=None, double=False, version=4, name="m") -> bytes:
    """One shape as Mitsuba writes it (the documented layout; see mcpt/shapes/serialized.py)."""
    real = "d" if double else "f"
    flags = (0x2000 if double else 0x1000) | (0x1 if normals is not None else 0) | (0x2 if uvs is not None else 0)
    body = struct.pack("<I", flags)
    if version == 4:
        body += name.encode() + b"\0"
    body += struct.pack("<QQ", len(pos), len(faces))
    for arr in (pos, normals, uvs):
        if arr is not None:
            body += struct.pack(f"<{np.size(arr)}{real}", *np.ravel(arr))
    body += struct.pack(f"<{np.size(faces)}I", *np.ravel(faces))
    return struct.pack("<HH", 0x041C, version) + zlib.compress(body)


def serialized_file(shapes: list[bytes], version=4) -> bytes:
    data, offsets = b"", []
    for s in shapes:
        offsets.append(len(data))
        data += s
    table = struct.pack(f"<{len(offsets)}{'Q' if version == 4 else 'I'}", *offsets)
    return data + table + struct.pack("<I", len(offsets))


@pytest.mark.parametrize("version,double", [(4, False), (4, True), (3, False)])
def test_serialized_round_trip(tmp_path, version, double):
    tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    quad = np.array([[0, 0, 1], [2, 0, 1], [2, 2, 1], [0, 2, 1]], float)
    qf = np.array([[0, 1, 2], [0, 2, 3]])
    nrm = np.tile([0.0, 0.0, 1.0], (4, 1))
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    path = tmp_path / "m.serialized"
    path.write_bytes(serialized_file([serialized_shape(tri, [[0, 1, 2]], version=version),
                                      serialized_shape(quad, qf, nrm, uv, double, version, "quad")], version))
    m = read_serialized(path, 1)
    np.testing.assert_array_equal(m.positions, quad)
    np.testing.assert_array_equal(m.faces, qf)
    np.testing.assert_array_equal(m.normals, nrm)
    np.testing.assert_array_equal(m.uvs, uv)
    assert m.name == ("quad" if version == 4 else "")
    np.testing.assert_array_equal(read_serialized(path, 0).positions, tri)
    with pytest.raises(SerializedError, match="shape_index 2 out of range"):
        read_serialized(path, 2)


def test_serialized_truncated_or_lying_is_one_error(tmp_path):
    pos = np.zeros((3, 3))
    good = serialized_shape(pos + np.eye(3), [[0, 1, 2]])
    path = tmp_path / "t.serialized"
    path.write_bytes(serialized_file([good[:-6]]))
    with pytest.raises(SerializedError, match="truncated|corrupt"):
        read_serialized(path)
    # A header announcing 2^40 vertices is refused before anything is allocated.
    body = struct.pack("<I", 0x1000) + b"x\0" + struct.pack("<QQ", 2**40, 1)
    path.write_bytes(serialized_file([struct.pack("<HH", 0x041C, 4) + zlib.compress(body)]))
    with pytest.raises(SerializedError, match="exceed"):
        read_serialized(path)
    path.write_bytes(b"not a mesh at all")
    with pytest.raises(SerializedError, match="not a Mitsuba .serialized"):
        read_serialized(path)


def test_serialized_shape_in_a_scene(tmp_path):
    quad = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float)
    (tmp_path / "q.serialized").write_bytes(serialized_file([serialized_shape(quad, [[0, 1, 2], [0, 2, 3]])]))
    path = write_xml(tmp_path, '<shape type="serialized"><string name="filename" value="q.serialized"/>'
                     '<boolean name="face_normals" value="true"/></shape>')
    from mcpt.shapes.mesh import assemble, read_geometry
    from mcpt.shapes.sources import source_of

    spec = load_scene(path).meshes[0]
    mesh = assemble(read_geometry(source_of(spec)), spec.transform.matrix())
    assert mesh.num_triangles == 2 and mesh.vertices[mesh.faces].reshape(-1, 3).max() == 1.0


# --- scene mapping -----------------------------------------------------------------------------

def test_defaults_substitute_and_D_overrides_them():
    scene = load_scene(DATA / "small.xml")
    assert scene.render.spp == 8 and scene.camera.resolution == (16, 16)
    scene = load_scene(DATA / "small.xml", overrides=("spp=3", "res=24", "camera.vfov_deg=30"))
    assert scene.render.spp == 3 and scene.camera.resolution == (24, 24) and scene.camera.vfov_deg == 30


def test_a_parameter_can_name_the_plugin():
    with pytest.raises(SceneError, match=r'small.xml:\d+: <bsdf type="hair">: not supported by mcpt'):
        load_scene(DATA / "small.xml", overrides=("wall=hair",))


def test_twosided_and_bare_bsdfs_and_smooth_spheres():
    data, _ = scene_data(DATA / "small.xml")
    mats = {m["material"]: data["materials"][m["material"]] for m in data["meshes"]}
    grey, ball, lamp = (mats[m["material"]] for m in data["meshes"])
    assert grey["two_sided"] is True and ball["two_sided"] is False
    assert ball["smooth_normals"] is True and "smooth_normals" not in grey
    assert lamp["emission"] == [5.0, 5.0, 5.0] and lamp["albedo"] == [0.0, 0.0, 0.0]


def test_instances_are_flattened_with_composed_transforms():
    data, _ = scene_data(DATA / "instances.xml")
    shapes = [(m["shape"], np.array(m.get("transform", {}).get("matrix", np.eye(4)))) for m in data["meshes"]]
    assert [s for s, _ in shapes] == ["sphere", "cube", "sphere", "cube"]
    np.testing.assert_allclose(shapes[0][1] @ [0, 0, 0, 1], [0, 2, 0, 1])     # translate y 2
    np.testing.assert_allclose(shapes[1][1] @ [0, 0, 0, 1], [1, 2, 0, 1])     # + member's x 1
    np.testing.assert_allclose(shapes[2][1] @ [1, 0, 0, 1], [0.3, 0, 0, 1])   # scale 3 x radius 0.1
    np.testing.assert_allclose(shapes[3][1] @ [0, 0, 0, 1], [3, 0, 0, 1])     # scale 3 of x 1


def test_plastic_nonlinear_mode_is_mapped_as_given(tmp_path):
    """Mitsuba's plastic defaults to nonlinear=false, mcpt's YAML plastic to true: the reader says
    which (the shader implements both, glsl/bsdf_plastic.glsl; textured albedos included)."""
    for flag, want in (("", False), ('<boolean name="nonlinear" value="true"/>', True)):
        path = write_xml(tmp_path, '<shape type="sphere"><bsdf type="plastic"><rgb name="diffuse_reflectance" '
                         f'value="0.5"/><float name="int_ior" value="1.5"/>{flag}</bsdf></shape>')
        mat = next(iter(scene_data(path)[0]["materials"].values()))
        assert mat["nonlinear"] is want and mat["albedo"] == [0.5, 0.5, 0.5]


# --- refusals: one line, file:line: <element>: reason ---------------------------------------------

REFUSALS = [
    ('<shape type="sphere"><bsdf type="principled"/></shape>',
     r'<bsdf type="principled">: not supported by mcpt \(supported: diffuse'),
    ('<shape type="bsplinecurve"/>', r'<shape type="bsplinecurve">: not supported by mcpt'),
    ('<emitter type="projector"/>', r'<emitter type="projector">: not supported by mcpt'),
    ('<integrator type="aov"/><shape type="sphere"/>',
     r'<integrator type="aov">: not supported by mcpt: its image differs'),
    ('<shape type="sphere"><ref id="nothing"/></shape>', r"<ref id=\"nothing\">: unknown reference id 'nothing'"),
    ('<shape type="sphere"><transform name="to_world"><scale x="2"/></transform></shape>', r"non-uniform scale"),
    ('<shape type="sphere"><bsdf type="conductor"><string name="material" value="Xx"/></bsdf></shape>',
     r"not among Mitsuba 3's presets"),
    ('<shape type="sphere"><float name="radius" value="$r"/></shape>', r"undefined parameter \$r"),
]


@pytest.mark.parametrize("body,pattern", REFUSALS)
def test_refusals_name_file_line_and_element(tmp_path, body, pattern):
    path = write_xml(tmp_path, body)
    with pytest.raises(SceneError) as err:
        load_scene(path)
    msg = str(err.value)
    assert "\n" not in msg
    assert re.match(rf"{re.escape(str(path))}:3: ", msg), msg  # the body is line 3
    assert re.search(pattern, msg), msg


def test_include_cycle_and_malformed_xml(tmp_path):
    cycle = r"cycle-b.xml:2: <include>: include cycle: cycle-a.xml -> cycle-b.xml -> cycle-a.xml"
    with pytest.raises(XmlError, match=cycle):
        load_scene(DATA / "cycle-a.xml")
    bad = tmp_path / "bad.xml"
    bad.write_text('<scene version="3.0.0">\n<shape type="sphere">\n</scene>\n')
    with pytest.raises(XmlError, match=r"bad.xml:3: malformed XML: mismatched tag"):
        load_scene(bad)


def test_absurd_film_is_refused_fast(tmp_path):
    path = write_xml(tmp_path, '<sensor type="perspective"><film type="hdrfilm"><integer name="width" '
                     'value="10000000000"/></film></sensor><shape type="sphere"/>', camera=False)
    t0 = time.perf_counter()
    with pytest.raises(XmlError, match=r"s.xml:3: <integer name=\"width\">: width 10000000000 out of range"):
        load_scene(path)
    assert time.perf_counter() - t0 < 1.0


def test_cli_refusal_exits_2_with_one_line_and_writes_nothing(tmp_path):
    out = tmp_path / "o.exr"
    res = subprocess.run([sys.executable, "-m", "mcpt", "render", str(DATA / "hair.xml"), "-o", str(out)],
                         capture_output=True, text=True)
    assert res.returncode == 2
    assert re.fullmatch(r'mcpt: error: \S*hair.xml:4: <bsdf type="hair">: not supported by mcpt \(supported: .*\)\n',
                        res.stderr), res.stderr
    assert not out.exists()


def test_convert_writes_yaml_that_loads_to_the_same_scene(tmp_path):
    out = tmp_path / "sub" / "c.yaml"
    res = subprocess.run([sys.executable, "-m", "mcpt", "convert", str(BENCH / "spheres-metal-glass.xml"),
                          "-o", str(out), "-D", "spp=5"], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    a, b = load_scene(out), load_scene(BENCH / "spheres-metal-glass.xml", overrides=("spp=5",))
    assert a.model_dump() == b.model_dump()


# --- pixels ------------------------------------------------------------------------------------

def test_xml_and_equivalent_yaml_render_the_same_pixels(gl):
    from mcpt.api import render_scene

    (ra, _), (rb, _) = (render_scene(DATA / name, seed=3) for name in ("small.xml", "small.yaml"))
    assert ra.image.mean() > 0.01
    np.testing.assert_allclose(ra.image, rb.image, rtol=1e-5, atol=1e-6)

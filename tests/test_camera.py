"""The camera on the real GLSL (tests/glsl/probe_camera.frag) and its scene keys (issue #22): thin
lens (chi-square of the lens disk, the focus plane sharp, bad input), orthographic, fov_axis, the
Mitsuba XML and glTF mappings, and a filtered depth-of-field render resumed bit for bit."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from mcpt.gpu.features import Features
from mcpt.scene.model import Camera
from mcpt.shading.camera import camera_uses

from .camera_probe import RES, camera, run_camera_probe, write_scene
from .test_materials_util import chi2_test, uniform_numbers

N = 1 << 19

# --- thin lens ---------------------------------------------------------------------------------

LENS = {"focus_distance": 3.0, "aperture_radius": 0.2}


def test_lens_samples_are_uniform_on_the_disk(gl):
    """chi-square of concentric_disk (Shirley & Chiu) against the uniform disk: r^2 and phi
    uniform, 16 x 32 equal-area cells."""
    cam = camera(lens=LENS, filter="gaussian")
    u = uniform_numbers(N, 2, seed=22)
    d = run_camera_probe(gl, cam, 3, u, np.zeros((N, 2))).astype(np.float64)[:, :2]
    r2 = (d * d).sum(axis=1)
    assert r2.max() <= 1.0 + 1e-6
    phi = (np.arctan2(d[:, 1], d[:, 0]) / (2 * math.pi)) % 1.0
    observed, _, _ = np.histogram2d(np.minimum(r2, 1.0), phi, bins=(16, 32), range=((0, 1), (0, 1)))
    p, stat, dof = chi2_test(observed, np.full(observed.shape, N / observed.size))
    print(f"lens disk: chi2 p = {p:.3g} ({stat:.1f} / {dof} dof)")
    assert p > 0.01, (p, stat, dof)


def test_focus_plane_is_sharp_and_the_lens_blurs_elsewhere(gl):
    """All lens points of one film position aim at the point the pinhole ray meets on the plane
    focus_distance ahead; the rays spread everywhere else (by the aperture, at the lens)."""
    cam = camera(lens=LENS)
    pin = camera()
    u = uniform_numbers(64, 2, seed=3)
    pix = np.stack([np.arange(64) % RES, np.arange(64) // 4 % RES], axis=1)
    ref = run_camera_probe(gl, pin, 1, u, pix).astype(np.float64)[:, :3]
    f = np.array([0.0, 0.0, -1.0])
    target = ref / (ref @ f)[:, None] * LENS["focus_distance"]
    origins = []
    for lens in [(0.1, 0.2), (0.9, 0.5), (0.5, 0.99), (0.3, 0.7), (0.0, 0.0)]:
        d = run_camera_probe(gl, cam, 1, u, pix, lens).astype(np.float64)[:, :3]
        o = run_camera_probe(gl, cam, 2, u, pix, lens).astype(np.float64)[:, :3]
        assert np.allclose(o @ f, 0.0, atol=1e-7)                        # on the lens plane
        assert np.all(np.linalg.norm(o, axis=1) <= LENS["aperture_radius"] * (1 + 1e-6))
        t = (LENS["focus_distance"] - o @ f) / (d @ f)
        np.testing.assert_allclose(o + t[:, None] * d, target, atol=2e-5)  # sharp in focus
        origins.append(o)
    spread = np.ptp(np.stack(origins), axis=0).max()
    assert spread > 0.2                                                   # the aperture is used


def test_zero_aperture_is_a_pinhole_and_the_lens_takes_two_more_dims():
    from mcpt.shading.sampler import dims_for

    assert camera_uses(camera(lens={"focus_distance": 2.0, "aperture_radius": 0.0}))["thin_lens"] is False
    f = Features.of(bounces=3, **camera_uses(camera(lens=LENS)))
    assert f.defines()["MCPT_THIN_LENS"] == 1 and f.random_dims == dims_for(3) + 2
    by_ratio = camera(lens={"focus_distance": 2.0, "f_number": 2.0, "focal_length": 0.05}).lens
    assert by_ratio.radius == pytest.approx(0.0125)


@pytest.mark.parametrize("lens,error", [
    ("{focus_distance: 0, aperture_radius: 0.1}", "focus_distance: Input should be greater than 0"),
    ("{focus_distance: -2, aperture_radius: 0.1}", "focus_distance: Input should be greater than 0"),
    ("{focus_distance: 2, aperture_radius: -0.1}", "aperture_radius: Input should be greater than or equal to 0"),
    ("{focus_distance: 2, f_number: 2}", "focal_length: f_number and focal_length go together"),
    ("{focus_distance: 2}", "a lens needs aperture_radius"),
])
def test_bad_lens_is_one_located_line(tmp_path, lens, error):
    from mcpt.scene import SceneError, load_scene

    path = write_scene(tmp_path, f"  vfov_deg: 40\n  lens: {lens}\n")
    with pytest.raises(SceneError) as e:
        load_scene(path)
    msg = str(e.value)
    assert "\n" not in msg and "s.yaml:6:" in msg and error in msg, msg


def test_aperture_larger_than_the_scene_exits_2_writing_nothing(tmp_path):
    from click.testing import CliRunner

    from mcpt.cli.main import main

    path = write_scene(tmp_path, "  vfov_deg: 40\n  lens: {focus_distance: 1, aperture_radius: 50}\n")
    out = tmp_path / "o.exr"
    res = CliRunner().invoke(main, ["render", str(path), "-o", str(out), "--spp", "1"])
    assert res.exit_code == 2 and not out.exists()
    errors = [ln for ln in res.output.splitlines() if "error" in ln]   # (and a no-emitter warning)
    assert len(errors) == 1, res.output
    assert "s.yaml:6: camera.lens: aperture radius 50 is larger than the whole scene" in errors[0], res.output


def test_mitsuba_thinlens_maps_exactly(tmp_path):
    from mcpt.scene import SceneError, load_scene

    def scene(params: str, transform='<lookat origin="0, 0, 4" target="0, 0, 0"/>'):
        p = tmp_path / "t.xml"
        p.write_text(f'''<scene version="3.0.0"><sensor type="thinlens">
            {params}<transform name="to_world">{transform}</transform>
            <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
            </sensor><shape type="sphere"/></scene>''')
        return p

    both = '<float name="aperture_radius" value="0.1"/><float name="focus_distance" value="3"/>'
    cam = load_scene(scene(both)).camera
    assert (cam.lens.radius, cam.lens.focus_distance, cam.filter.type) == (0.1, 3.0, "gaussian")
    assert load_scene(scene('<float name="aperture_radius" value="0.1"/>')).camera.lens.focus_distance == 1e4
    for params, transform, words in (
            ("", None, "a thinlens sensor needs aperture_radius"),
            ('<float name="aperture_radius" value="0.1"/><float name="focus_distance" value="0"/>', None,
             "focus_distance 0 must be > 0"),
            ('<float name="aperture_radius" value="0.1"/>', '<scale value="2"/>', "has a scale")):
        with pytest.raises(SceneError) as e:
            load_scene(scene(params, *([transform] if transform else [])))
        msg = str(e.value)
        assert "\n" not in msg and "t.xml:" in msg and words in msg, msg


# --- orthographic ------------------------------------------------------------------------------

def test_orthographic_rays_are_parallel_over_the_view(gl):
    """Origins on the plane through the camera, spanning ortho_height x (height * aspect), every
    direction the view direction; pixel (i, j) from the left and the top as for the pinhole."""
    cam = Camera.model_validate({"position": (1.0, 2.0, 3.0), "look_at": (1.0, 2.0, 0.0),
                                 "projection": "orthographic", "ortho_height": 2.5, "resolution": (20, 10)})
    assert camera_uses(cam)["orthographic"] and not camera_uses(cam)["thin_lens"]
    pix = np.array([[0, 0], [19, 9], [10, 5], [3, 7]])
    u = np.array([[0.0, 0.0], [1.0, 1.0], [0.0, 0.0], [0.5, 0.5]], np.float32)
    o = run_camera_probe(gl, cam, 2, u, pix).astype(np.float64)[:, :3]
    d = run_camera_probe(gl, cam, 1, u, pix).astype(np.float64)[:, :3]
    np.testing.assert_allclose(d, np.tile([0.0, 0.0, -1.0], (4, 1)), atol=1e-7)
    # camera-relative origins: right = +x, up = +y; width 2.5 * 2 = 5
    expected = [[-2.5, 1.25, 0], [2.5, -1.25, 0], [0, 0, 0], [-2.5 + 3.5 * 0.25, 1.25 - 7.5 * 0.25, 0]]
    np.testing.assert_allclose(o, expected, atol=1e-6)


@pytest.mark.parametrize("lines,error", [
    ("  projection: orthographic\n", "camera.ortho_height: required key is missing"),
    ("  projection: orthographic\n  ortho_height: 2\n  vfov_deg: 30\n",
     "camera.vfov_deg: vfov_deg is for a perspective"),
    ("  projection: orthographic\n  ortho_height: -1\n", "camera.ortho_height: Input should be greater than 0"),
    ("  vfov_deg: 30\n  ortho_height: 2\n", "camera.ortho_height: ortho_height is for projection: orthographic"),
    ("  resolution_: 1\n", "unknown key"),
])
def test_bad_orthographic_is_one_located_line(tmp_path, lines, error):
    from mcpt.scene import SceneError, load_scene

    with pytest.raises(SceneError) as e:
        load_scene(write_scene(tmp_path, lines))
    msg = str(e.value)
    assert "\n" not in msg and "s.yaml:" in msg and error in msg, msg


def test_mitsuba_orthographic_and_gltf_orthographic_map_exactly(tmp_path):
    from mcpt.scene import SceneError, load_scene
    from mcpt.scene.gltf import GltfError

    from .gltf_files import QUAD, QUAD_FACES, GltfBuilder

    def xml(scale: str):
        p = tmp_path / "o.xml"
        p.write_text(f'''<scene version="3.0.0"><sensor type="orthographic"><transform name="to_world">
            {scale}<lookat origin="0, 0, 4" target="0, 0, 0"/></transform>
            <film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="20"/></film>
            </sensor><shape type="sphere"/></scene>''')
        return p

    cam = load_scene(xml('<scale x="3" y="3" z="7"/>')).camera
    assert cam.projection == "orthographic" and cam.ortho_height == pytest.approx(3.0)  # 2 * 3 / aspect 2
    assert cam.position == (0, 0, 4) and np.allclose(np.subtract(cam.look_at, cam.position), [0, 0, -1])
    assert load_scene(xml("")).camera.ortho_height == pytest.approx(1.0)
    with pytest.raises(SceneError, match=r"o.xml:1: <transform name=\"to_world\">: to_world scales x and y "
                                         r"differently \(3, 2\)"):
        load_scene(xml('<scale x="3" y="2"/>'))

    b = GltfBuilder()
    b.node(mesh=b.mesh(QUAD, QUAD_FACES))
    b.doc.setdefault("cameras", []).append({"type": "orthographic", "orthographic":
                                            {"xmag": 3.0, "ymag": 1.5, "znear": 0.01, "zfar": 100}})
    b.node(translation=[0, 0, 5], camera=0)
    cam = load_scene(b.write_gltf(tmp_path / "o.gltf")).camera
    assert (cam.projection, cam.ortho_height, cam.resolution) == ("orthographic", 3.0, (1024, 512))
    assert cam.position == (0, 0, 5)
    b.doc["cameras"][0]["orthographic"]["ymag"] = 0
    with pytest.raises(GltfError, match=r"bad.gltf: cameras\[0\]: orthographic.ymag 0 is not a positive number"):
        load_scene(b.write_gltf(tmp_path / "bad.gltf"))


# --- fov_axis ----------------------------------------------------------------------------------

@pytest.mark.parametrize("axis", ["x", "y", "diagonal", "smaller", "larger"])
def test_yaml_fov_axis_is_mitsubas(axis):
    """fov_deg along fov_axis gives the vertical fov that the Mitsuba reader derives from the same
    fov and fov_axis (tests/test_mitsuba.py holds that one against Mitsuba's own parse_fov)."""
    from mcpt.scene.mitsuba.camera import vfov_deg, x_fov
    from mcpt.scene.mitsuba.xmltree import Node

    for w, h in ((32, 16), (16, 32)):
        cam = camera(fov_deg=40.0, fov_axis=axis, vfov_deg=None, resolution=(w, h))
        props = {"fov": Node("float", {"name": "fov", "value": "40"}, Path("t.xml"), 1),
                 "fov_axis": Node("string", {"name": "fov_axis", "value": axis}, Path("t.xml"), 1)}
        expected = vfov_deg(x_fov(props, w / h, Node("sensor", {}, Path("t.xml"), 1)), w / h)
        assert cam.vfov_deg == pytest.approx(expected, rel=1e-12)
    assert camera(fov_deg=40.0, vfov_deg=None).vfov_deg == pytest.approx(40.0)  # square: any axis


def test_fov_axis_follows_a_new_resolution(tmp_path):
    from mcpt.scene import load_scene

    scene = load_scene(write_scene(tmp_path, "  fov_deg: 60\n  fov_axis: x\n"))
    wide = scene.with_overrides(resolution=(16, 8)).camera
    assert wide.vfov_deg == pytest.approx(2 * math.degrees(math.atan(math.tan(math.radians(30)) / 2)))
    assert wide.fov_deg == 60 and scene.camera.vfov_deg == pytest.approx(60)


@pytest.mark.parametrize("lines,error", [
    ("  fov_deg: 60\n  vfov_deg: 60\n", "camera.fov_deg: give vfov_deg or fov_deg"),
    ("  vfov_deg: 60\n  fov_axis: y\n", "camera.fov_axis: fov_axis goes with fov_deg"),
    ("  fov_deg: 60\n  fov_axis: z\n", "camera.fov_axis: Input should be"),
    ("  fov_deg: 180\n", "camera.fov_deg: Input should be less than 180"),
])
def test_bad_fov_is_one_located_line(tmp_path, lines, error):
    from mcpt.scene import SceneError, load_scene

    with pytest.raises(SceneError) as e:
        load_scene(write_scene(tmp_path, lines))
    msg = str(e.value)
    assert "\n" not in msg and "s.yaml:" in msg and error in msg, msg


def test_filtered_thin_lens_render_resumes_bit_identically(tmp_path, monkeypatch):
    """Each sample still lands in one pixel: a Gaussian-filtered depth-of-field render stopped at
    72 spp and resumed to 130 has the bits of one uninterrupted 130-spp render."""
    from click.testing import CliRunner

    from mcpt.cli.main import main

    scene = tmp_path / "dof.yaml"
    scene.write_text("""camera: {position: [0, 0, 3], look_at: [0, 0, 0], vfov_deg: 40, resolution: [12, 10],
         filter: gaussian, lens: {focus_distance: 3, aperture_radius: 0.2}}
render: {bounces: 2}
materials:
  lamp: {albedo: [0, 0, 0], emission: [4, 4, 4]}
  grey: {albedo: [0.5, 0.5, 0.5]}
meshes:
  - {shape: sphere, material: grey, transform: {scale: 0.6, translate: [0.3, 0, -1]}}
  - {shape: rectangle, material: lamp, transform: {translate: [-0.5, 0.4, 0.5], scale: 0.3}}
""")
    monkeypatch.chdir(tmp_path)
    run = CliRunner().invoke
    first = run(main, ["render", "dof.yaml", "--spp", "72", "--checkpoint", "1000", "-o", "a.exr", "--quiet"])
    assert first.exit_code == 0, first.output
    r = run(main, ["render", "dof.yaml", "--spp", "130", "--resume", "-o", "a.exr", "--quiet", "--json"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["resumed_from"] in (64, 72)   # carried on, not rendered again
    assert run(main, ["render", "dof.yaml", "--spp", "130", "-o", "b.exr", "--quiet"]).exit_code == 0
    from mcpt.output.image import read_exr
    a, b = read_exr(tmp_path / "a.exr")[0], read_exr(tmp_path / "b.exr")[0]
    assert a.max() > 0 and np.array_equal(a.view(np.uint32), b.view(np.uint32))

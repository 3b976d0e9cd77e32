"""AOV layers and denoising (issue #12): channel names and shapes, albedo / normal / depth against
what the scene says analytically, variance against the spread of independent renders, and
--denoise's raw layer, header flag and missing-extra error.

Scenes are a few big quads seen by a 16x12 camera: a pass costs well under a millisecond.
"""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest
from click.testing import CliRunner

from mcpt.api import prepare
from mcpt.cli.main import main
from mcpt.gpu.aov import AOVS, AovError, channel_names, parse
from mcpt.output.image import read_exr, read_exr_channels
from mcpt.scene import load_scene

from .conftest import ROOT
from .draw import render as draw

WALL_ALBEDO = [0.6, 0.4, 0.2]
BACK_ALBEDO = [0.2, 0.7, 0.3]
PLANE_Z = 2.0  # the wall in front of the camera is the plane z = -PLANE_Z


def quad(z: float, facing: float, half: float = 10.0) -> str:
    """A square at depth z, its front (counter-clockwise) facing +z (facing=1) or -z (-1)."""
    v = f"v {-half} {-half} {z}\nv {half} {-half} {z}\nv {half} {half} {z}\nv {-half} {half} {z}\n"
    return v + ("f 1 2 3\nf 1 3 4\n" if facing > 0 else "f 1 3 2\nf 1 4 3\n")


LIGHT_OBJ = "v -0.5 3 -1.5\nv 0.5 3 -1.5\nv 0.5 3 -0.5\nv -0.5 3 -0.5\nf 1 3 2\nf 1 4 3\n"

SCENE = """\
camera:
  position: [0, 0, 0]
  look_at: [0, 0, -1]
  up: [0, 1, 0]
  vfov_deg: 40
  resolution: [16, 12]
render:
  spp: 16
  bounces: 3
  seed: 3
materials:
  wall: {{albedo: {wall}}}
  back: {{albedo: {back}}}
  lamp: {{albedo: [0, 0, 0], emission: [10, 10, 10]}}
  mirror: {{type: conductor, albedo: [0.95, 0.95, 0.95], roughness: 0.0}}
meshes:
  - {{file: front.obj, material: {front}}}
  - {{file: back.obj, material: back}}
  - {{file: light.obj, material: lamp}}
"""


@pytest.fixture
def folder(tmp_path, monkeypatch):
    (tmp_path / "front.obj").write_text(quad(-PLANE_Z, +1))
    (tmp_path / "back.obj").write_text(quad(3.0, -1))  # behind the camera, facing it
    (tmp_path / "light.obj").write_text(LIGHT_OBJ)
    for front in ("wall", "mirror"):
        (tmp_path / f"{front}.yaml").write_text(SCENE.format(wall=WALL_ALBEDO, back=BACK_ALBEDO,
                                                             front=front))
    monkeypatch.chdir(tmp_path)
    return tmp_path


def render(scene, spp=16, seed=3, aovs=("albedo", "normal", "depth"), **kw):
    p = prepare(load_scene(scene), aovs=aovs, **kw)
    try:
        total = sum(sums for _, sums in p.renderer.passes(seed, 0, spp))
        return p.renderer.result(total, spp, seed, 0.0, 0.0), total, p.renderer.aov_target
    finally:
        p.renderer.release()


def expected_plane_depth(width=16, height=12, vfov=40.0, n=64) -> np.ndarray:
    """Mean over each pixel (n x n midpoint quadrature) of the distance from the camera to the
    plane z = -PLANE_Z along the ray: PLANE_Z / |d_z| = PLANE_Z * sqrt(1 + x^2 + y^2) with x, y
    the ray's slopes (mcpt/shading/camera.py)."""
    t = math.tan(math.radians(vfov) / 2)
    s = (np.arange(n) + 0.5) / n
    i = np.arange(width)[:, None] + s[None, :]          # (W, n) sub-pixel x
    j = np.arange(height)[:, None] + s[None, :]         # (H, n)
    x = (2 * i / width - 1) * t * width / height
    y = (1 - 2 * j / height) * t
    d = PLANE_Z * np.sqrt(1 + x[None, :, None, :] ** 2 + y[:, None, :, None] ** 2)  # (H, W, n, n)
    return d.mean(axis=(2, 3))


def test_parse_names_and_channel_order():
    assert parse("depth, albedo") == ("albedo", "depth")
    assert parse(["variance", "normal"]) == ("normal", "variance")
    assert parse("") == ()
    with pytest.raises(AovError, match="unknown AOV 'colour'"):
        parse("albedo,colour")
    assert channel_names(AOVS) == ["albedo.R", "albedo.G", "albedo.B", "normal.X", "normal.Y",
                                   "normal.Z", "depth.Z", "variance.R", "variance.G", "variance.B"]


def test_cli_writes_every_layer_with_its_shape_and_lists_them(folder):
    r = CliRunner().invoke(main, ["render", "wall.yaml", "--aov", "albedo,normal,depth,variance",
                                  "-o", "a.exr", "-o", "a.png", "--quiet"])
    assert r.exit_code == 0, r.output
    ch = read_exr_channels("a.exr")
    assert set(ch) == {"R", "G", "B", *channel_names(AOVS)}
    assert all(v.shape == (12, 16) and v.dtype == np.float32 for v in ch.values())
    _, header = read_exr("a.exr")
    assert header["mcpt:aovs"] == "albedo,normal,depth,variance"
    assert "mcpt:denoised" not in header
    assert (folder / "a.png").is_file()


def test_unknown_aov_is_one_line(folder):
    r = CliRunner().invoke(main, ["render", "wall.yaml", "--aov", "albedo,z", "-o", "a.exr", "--quiet"])
    assert r.exit_code == 2
    assert len(r.stderr.strip().splitlines()) == 1 and "unknown AOV 'z'" in r.stderr


def test_beauty_is_the_same_with_or_without_aovs(folder):
    plain, _, _ = render("wall.yaml", aovs=())
    with_aovs, _, _ = render("wall.yaml")
    np.testing.assert_array_equal(plain.image, with_aovs.image)
    assert plain.aovs == {}


def test_diffuse_wall_seen_directly(folder):
    res, total, a = render("wall.yaml", spp=64)
    # Every sample of every pixel sees the wall: the albedo is the material's (float32 sums of one
    # value: a few ulps), the normal its +z, unit and facing the camera (which looks down -z).
    np.testing.assert_allclose(res.aovs["albedo"], np.broadcast_to(WALL_ALBEDO, (12, 16, 3)), rtol=1e-6)
    np.testing.assert_allclose(res.aovs["normal"], np.broadcast_to([0, 0, 1], (12, 16, 3)), atol=1e-6)
    # Depth: the pixel's mean distance to the plane (Sobol' jitter over 64 samples of a smooth
    # function: far below 1e-3 of it).
    np.testing.assert_allclose(res.aovs["depth"][..., 0], expected_plane_depth(), rtol=1e-3)
    np.testing.assert_array_equal(total[a + 1][..., 3], 64)  # one AOV event per sample


def test_albedo_and_normal_follow_a_mirror(folder):
    """The front wall is a mirror: albedo and normal are those of the wall behind the camera
    that it shows (OIDN's first non-specular vertex), depth still the distance to the mirror."""
    res, _, _ = render("mirror.yaml", spp=16)
    np.testing.assert_allclose(res.aovs["albedo"], np.broadcast_to(BACK_ALBEDO, (12, 16, 3)), rtol=1e-6)
    np.testing.assert_allclose(res.aovs["normal"], np.broadcast_to([0, 0, -1], (12, 16, 3)), atol=1e-6)
    np.testing.assert_allclose(res.aovs["depth"][..., 0], expected_plane_depth(), rtol=1e-3)


def test_escaping_rays_give_zero(folder):
    """A camera beyond the quads' edge (they span x in [-10, 10]) looking further out: all AOVs 0."""
    sc = load_scene("wall.yaml", overrides=("camera.position=[30,0,0]", "camera.look_at=[40,0,0]"))
    p = prepare(sc, aovs=("albedo", "normal", "depth"))
    try:
        res = draw(p.renderer, 8, 1)
    finally:
        p.renderer.release()
    for name in ("albedo", "normal", "depth"):
        assert not res.aovs[name].any(), name


def test_normals_unit_and_facing_the_camera_in_the_cornell_box():
    from .rays import primary_rays

    sc = load_scene(ROOT / "scenes" / "cornell-box.yaml")
    p = prepare(sc, resolution=(24, 24), aovs=("normal",))
    try:
        res = draw(p.renderer, 16, 2)
    finally:
        p.renderer.release()
    n = res.aovs["normal"].astype(np.float64)
    length = np.linalg.norm(n, axis=-1)
    seen = length > 0
    assert seen.mean() > 0.9
    np.testing.assert_allclose(length[seen], 1.0, atol=1e-5)
    cam = sc.camera
    _, d = primary_rays(cam.position, cam.look_at, cam.up, cam.vfov_deg, 24, 24)
    assert (np.einsum("hwc,hwc->hw", n, -d)[seen] > 0).all()


def test_aov_state_survives_path_continuation():
    """An inward mirror sphere with 2000 bounces: paths outlive a draw's loop budget on llvmpipe
    and are continued (glsl/path_state.glsl), never meeting a non-specular vertex: each sample
    must still add exactly one (zero) AOV event, in whichever draw it ends."""
    sc = load_scene(ROOT / "scenes" / "furnace.yaml", overrides=(
        "render.bounces=2000", "materials.furnace.type=conductor", "materials.furnace.roughness=0",
        "materials.furnace.albedo=[0.999,0.999,0.999]", "materials.furnace.emission=[0,0,0]"))
    p = prepare(sc, resolution=(8, 8), aovs=("albedo", "normal", "depth"))
    try:
        total = sum(s for _, s in p.renderer.passes(1, 0, 4))
        res = p.renderer.result(total, 4, 1, 0.0, 0.0)
        draws = p.renderer.paths.draws if p.renderer.paths is not None else 0
    finally:
        p.renderer.release()
    a = p.renderer.aov_target
    np.testing.assert_array_equal(total[a + 1][..., 3], 4)
    assert not res.aovs["albedo"].any() and not res.aovs["normal"].any()
    np.testing.assert_allclose(res.aovs["depth"], 1.0, atol=0.01)  # radius-1 sphere, tessellated
    if p.features.continues:
        assert draws > 0


def test_variance_agrees_with_the_spread_of_independent_renders(folder):
    """variance.* (variance of the mean, from one render's squares) against the variance of the
    means of 12 renders with different seeds (independent numbers: Sobol' points are not
    independent and their mean varies less than sample variance / n says)."""
    spp, seeds = 8, range(12)
    means, reported = [], []
    for s in seeds:
        p = prepare(load_scene("wall.yaml"), aovs=("variance",), sampler="independent")
        try:
            res = draw(p.renderer, spp, 100 + s)
        finally:
            p.renderer.release()
        means.append(res.image.astype(np.float64))
        reported.append(res.variance.astype(np.float64))
    spread = np.var(means, axis=0, ddof=1)    # (H, W, 3)
    mean_reported = np.mean(reported, axis=0)
    # Over 192 pixels x 3 channels, each spread from 12 renders (11 degrees of freedom): the ratio of
    # the totals is within a few percent of 1 in expectation; 25 % leaves room for heavy tails.
    ratio = spread.sum() / mean_reported.sum()
    assert 0.75 < ratio < 1.33, ratio


def test_denoise_writes_raw_and_says_so(folder):
    pytest.importorskip("pyoidn")
    r = CliRunner().invoke(main, ["render", "wall.yaml", "--denoise", "--aov", "depth",
                                  "-o", "d.exr", "-o", "d.png", "--quiet"])
    assert r.exit_code == 0, r.output
    ch = read_exr_channels("d.exr")
    assert {"raw.R", "raw.G", "raw.B", "depth.Z"} <= set(ch) and "albedo.R" not in ch
    image, header = read_exr("d.exr")
    assert header["mcpt:denoised"].startswith("oidn ") and header["mcpt:denoised"].endswith("biased")
    raw = np.stack([ch["raw.R"], ch["raw.G"], ch["raw.B"]], axis=-1)
    plain, _, _ = render("wall.yaml", aovs=())
    np.testing.assert_array_equal(raw, plain.image)   # the raw beauty is the render, untouched
    assert not np.array_equal(image, raw)             # the image is the denoised one
    import cv2

    from mcpt.output.image import to_srgb8

    png = cv2.imread("d.png", cv2.IMREAD_UNCHANGED)[..., ::-1]
    np.testing.assert_array_equal(png, to_srgb8(image))  # and so is the PNG
    # The denoised wall is smoother than the 16-spp beauty.
    assert np.std(np.diff(image, axis=1)) < np.std(np.diff(raw, axis=1))


def test_denoise_without_pyoidn_is_one_line(folder, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyoidn", None)  # import pyoidn -> ImportError
    monkeypatch.setitem(sys.modules, "pyoidn.version", None)
    r = CliRunner().invoke(main, ["render", "wall.yaml", "--denoise", "-o", "d.exr", "--quiet"])
    assert r.exit_code == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "pip install 'mcpt[denoise]'" in lines[0], lines
    assert not (folder / "d.exr").exists()


def test_info_lists_the_aovs(folder):
    r = CliRunner().invoke(main, ["info", "wall.yaml"])
    assert r.exit_code == 0, r.output
    for name in AOVS:
        assert f"  {name}: " in r.output
    assert "depth.Z" in r.output


def test_aovs_resume_bit_identically_and_refuse_another_set(folder):
    """A render stopped inside a chunk (here: 68 spp, on the draw grid, then --resume to 100)
    with AOVs resumes to the very layers of an uninterrupted render; a resume asking for other
    AOV targets is refused with one line."""
    def run(*a):
        return CliRunner().invoke(main, ["render", "wall.yaml", "--aov", "albedo,depth,variance",
                                         "--quiet", *a])

    assert run("--spp", "68", "--checkpoint", "1000", "-o", "c.exr").exit_code == 0
    r = run("--spp", "100", "--resume", "-o", "c.exr")
    assert r.exit_code == 0, r.output
    assert run("--spp", "100", "-o", "u.exr").exit_code == 0
    a, b = read_exr_channels("c.exr"), read_exr_channels("u.exr")
    assert set(a) == set(b) and all(np.array_equal(a[k], b[k]) for k in a)
    r = CliRunner().invoke(main, ["render", "wall.yaml", "--spp", "120", "--resume", "-o", "c.exr",
                                  "--quiet"])
    assert r.exit_code == 2
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "rendered with the AOVs albedo,depth,variance, this render asks for none" in r.stderr, r.stderr


def test_farm_renders_the_same_layers(folder):
    """Dask workers compute the AOV targets too: the farm's EXR equals one process's, every
    channel bit for bit."""
    pytest.importorskip("distributed")
    from distributed import Client

    from mcpt.farm.cluster import local_cluster
    from mcpt.farm.signals import StopSignals
    from mcpt.render import Options
    from mcpt.render import render as run

    aovs = ("albedo", "normal", "depth", "variance")
    cluster = local_cluster(1, lp_threads=1)
    try:
        with Client(cluster) as client:
            for out, c in (("one.exr", None), ("farm.exr", client)):
                run(folder / "wall.yaml", Options([str(folder / out)], spp=70, aovs=aovs, client=c),
                    StopSignals())
    finally:
        cluster.close()
    a, b = read_exr_channels("one.exr"), read_exr_channels("farm.exr")
    assert set(a) == set(b) == {"R", "G", "B", *channel_names(aovs)}
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)


# ---- mcpt merge keeps the layers ----------------------------------------------------------------

def _cli(*args):
    return CliRunner().invoke(main, list(args))


def test_merge_keeps_every_layer_spp_weighted(folder):
    """Albedo and depth merge like the beauty (spp-weighted, as one render of all passes), the
    normal too and back to unit length (approximate at edge pixels), the variance of each mean as
    that of the weighted mean: sum w_i^2 var_i."""
    aovs = "albedo,normal,depth,variance"
    for seed, spp in ((1, 16), (2, 48)):
        r = _cli("render", "mirror.yaml", "--aov", aovs, "--seed", str(seed), "--spp", str(spp),
                 "-o", f"s{seed}.exr", "--quiet")
        assert r.exit_code == 0, r.output
    r = _cli("merge", "s1.exr", "s2.exr", "-o", "m.exr")
    assert r.exit_code == 0, r.output
    assert "layers albedo,normal,depth,variance" in r.stderr
    a, b, m = (read_exr_channels(f) for f in ("s1.exr", "s2.exr", "m.exr"))
    assert set(m) == set(a)
    assert read_exr("m.exr")[1]["mcpt:aovs"] == aovs
    for k in ("R", "albedo.G", "depth.Z"):
        want = ((16 * a[k].astype(np.float64) + 48 * b[k].astype(np.float64)) / 64).astype(np.float32)
        assert np.array_equal(m[k], want), k
    assert not np.array_equal(a["albedo.R"], b["albedo.R"])  # the mirror's edges: noisy albedo
    w1, w2 = 0.25, 0.75
    var = (w1 * w1 * a["variance.G"].astype(np.float64)
           + w2 * w2 * b["variance.G"].astype(np.float64)).astype(np.float32)
    assert np.array_equal(m["variance.G"], var)
    n = np.stack([m[f"normal.{c}"] for c in "XYZ"], -1)
    length = np.linalg.norm(n, axis=-1)
    assert np.allclose(length[length > 0], 1.0, atol=1e-6)
    mixed = np.stack([16 * a[f"normal.{c}"] + 48 * b[f"normal.{c}"] for c in "XYZ"], -1)
    cos = (n * mixed).sum(-1) / np.maximum(np.linalg.norm(mixed, axis=-1), 1e-12)
    assert np.allclose(cos[length > 0], 1.0, atol=1e-5)  # the weighted mean's direction


def test_merge_refuses_renders_with_other_layers(folder):
    assert _cli("render", "wall.yaml", "--aov", "albedo", "--seed", "1", "-o", "a.exr", "--quiet").exit_code == 0
    assert _cli("render", "wall.yaml", "--aov", "depth", "--seed", "2", "-o", "b.exr", "--quiet").exit_code == 0
    r = _cli("merge", "a.exr", "b.exr", "-o", "m.exr")
    assert r.exit_code == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "AOV layers (depth) differ" in lines[0] and "(albedo)" in lines[0], lines
    assert not (folder / "m.exr").exists()


def test_merge_denoise_needs_albedo_and_normal(folder):
    pytest.importorskip("pyoidn")
    for seed in (1, 2):
        assert _cli("render", "wall.yaml", "--aov", "depth", "--seed", str(seed), "-o", f"s{seed}.exr",
                    "--quiet").exit_code == 0
    r = _cli("merge", "s1.exr", "s2.exr", "--denoise", "-o", "m.exr")
    assert r.exit_code == 2
    assert r.stderr.strip().splitlines() == [
        "mcpt: error: --denoise needs the albedo and normal layers in every input (render them with "
        "--aov albedo,normal)"]
    assert not (folder / "m.exr").exists()


def test_merge_of_denoised_renders_merges_their_raw_beauty_and_can_denoise_it(folder):
    pytest.importorskip("pyoidn")
    for seed in (1, 2):
        r = _cli("render", "wall.yaml", "--denoise", "--aov", "albedo,normal", "--seed", str(seed),
                 "--spp", "8", "-o", f"s{seed}.exr", "--quiet")
        assert r.exit_code == 0, r.output
    a, b = read_exr_channels("s1.exr"), read_exr_channels("s2.exr")
    r = _cli("merge", "s1.exr", "s2.exr", "-o", "raw.exr")
    assert r.exit_code == 0 and "their raw beauty was merged (--denoise denoises the merge)" in r.stderr
    m, hdr = read_exr_channels("raw.exr", with_header=True)
    assert np.array_equal(m["G"], ((a["raw.G"].astype(np.float64) + b["raw.G"].astype(np.float64)) / 2)
                          .astype(np.float32))
    assert "mcpt:denoised" not in hdr and "raw.G" not in m  # unbiased: no denoised beauty
    r = _cli("merge", "s1.exr", "s2.exr", "--denoise", "-o", "d.exr")
    assert r.exit_code == 0, r.output
    d, hdr = read_exr_channels("d.exr", with_header=True)
    assert hdr["mcpt:denoised"].endswith(", biased")
    assert np.array_equal(d["raw.G"], m["G"]) and not np.array_equal(d["G"], m["G"])

"""Point, spot and directional lights (issue #20): closed forms through the real path tracer,
the light table, and what bad input gets."""

import math

import numpy as np
import pytest

from mcpt.gpu.features import for_world
from mcpt.scene import SceneError, parse_scene
from mcpt.shading.camera import basis
from mcpt.shading.light_punctual import spot_falloff
from mcpt.shapes.world import load_world

from .conftest import ROOT
from .draw import render as draw
from .test_materials_util import renderer

RHO = 0.5
PLANE = f"""
camera: {{position: [0, 0, 3], look_at: [0, 0, 0], vfov_deg: 30, resolution: [16, 16]}}
render: {{bounces: {{b}}}}
materials:
  grey: {{albedo: [{RHO}, {RHO}, {RHO}]}}
meshes:
  - file: models/quad.obj
    material: grey
    transform: {{scale: 6}}
lights:
"""


def scene(lights: str, bounces: int = 1):
    return parse_scene(PLANE.replace("{b}", str(bounces)) + lights, ROOT / "scenes" / "inline.yaml")


def render(gl, sc, spp=64, seed=3, **flags):
    world = load_world(sc)
    feats = for_world(world, variance=True, **flags)
    r = renderer(gl, world, feats)
    try:
        return draw(r, spp, seed), feats
    finally:
        r.release()


def film_points(sc, n=256):
    """Where a dense grid of camera rays over the whole film meets the plane z = 0."""
    cam = sc.camera
    f, r, u = basis(cam.position, cam.look_at, cam.up, cam.vfov_deg, cam.width, cam.height)
    s = (np.arange(n) + 0.5) / n * 2 - 1
    sx, sy = np.meshgrid(s, s)
    d = f + sx[..., None] * r + sy[..., None] * u
    o = np.asarray(cam.position, np.float64)
    t = -o[2] / d[..., 2]
    return o + t[..., None] * d


def test_directional_light_on_a_plane_is_rho_over_pi_e_cos(gl):
    """A diffuse plane under a sun of irradiance E: L = rho / pi * E * cos(theta), every pixel."""
    d = np.array([0.0, -0.5, -1.0])
    res, feats = render(gl, scene("  - {type: directional, direction: [0, -0.5, -1], irradiance: [2, 1, 0.5]}"), 16)
    assert feats.defines()["MCPT_LIGHT_DIRECTIONAL"] == 1 and feats.defines()["MCPT_LIGHT_POINT"] == 0
    cos = -d[2] / np.linalg.norm(d)
    want = RHO / math.pi * np.array([2, 1, 0.5]) * cos
    np.testing.assert_allclose(res.image.reshape(-1, 3), np.broadcast_to(want, (256, 3)), rtol=2e-5)


def test_point_light_on_a_plane_is_rho_over_pi_i_cos_over_r2(gl):
    """A diffuse plane under a point light of intensity I at height h: L = rho / pi * I cos / r^2
    with cos = h / r; the image mean is that averaged over the film."""
    light = np.array([0.3, 0.2, 1.0])
    res, feats = render(gl, scene("  - {type: point, position: [0.3, 0.2, 1.0], intensity: [3, 3, 3]}"), 64)
    assert feats.defines()["MCPT_LIGHT_POINT"] == 1 and feats.defines()["MCPT_LIGHT_AREA"] == 0
    p = film_points(scene("  - {type: point, position: [0.3, 0.2, 1.0], intensity: [3, 3, 3]}"))
    v = light - p
    r2 = (v * v).sum(-1)
    want = RHO / math.pi * 3.0 * (v[..., 2] / np.sqrt(r2)) / r2
    assert res.image.mean() == pytest.approx(want.mean(), rel=2e-3)


def test_spot_light_on_a_plane_follows_mitsubas_profile(gl):
    """A spot aimed straight down: rho / pi * I falloff(theta) cos / r^2 (falloff: linear in angle
    from the beam to the cutoff, Mitsuba 3's spot.cpp), averaged over the film."""
    sc = scene("  - {type: spot, position: [0, 0, 1.5], look_at: [0, 0, 0], intensity: [4, 4, 4], "
               "cutoff_deg: 30, beam_deg: 10}")
    res, feats = render(gl, sc, 64)
    assert feats.defines()["MCPT_LIGHT_SPOT"] == 1
    v = np.array([0, 0, 1.5]) - film_points(sc)
    r = np.linalg.norm(v, axis=-1)
    cos = v[..., 2] / r
    want = RHO / math.pi * 4.0 * spot_falloff(cos, math.radians(30), math.radians(10)) * cos / r**2
    assert res.image.mean() == pytest.approx(want.mean(), rel=3e-3)


def test_spot_falloff_is_mitsubas():
    """Values read off Mitsuba 3.9.1's spot (cutoff 30, beam 10): 1 to the beam, 0.5 at 20
    degrees, 0.05 at 29, 0 past the cutoff."""
    ang = np.radians([0, 10, 12, 20, 29, 31])
    got = spot_falloff(np.cos(ang), math.radians(30), math.radians(10))
    np.testing.assert_allclose(got, [1, 1, 0.9, 0.5, 0.05, 0], atol=1e-5)


def test_lights_and_area_lights_share_one_selection(gl):
    """A point light beside an emissive quad: the picture is the sum of the two lit alone (within
    noise; the quad stays in the scene, dark, when it is off), and the pmf is power-proportional
    over both kinds."""
    lamp = """
  - file: models/quad.obj
    material: lamp
    transform: {translate: [0, 0, 1.5], rotate_deg: [180, 0, 0], scale: 0.5}
lights:
"""
    point = "  - {type: point, position: [0.5, 0, 1.0], intensity: [1, 1, 1]}\n"

    def sc(emission, lights):
        text = PLANE.replace("{b}", "2").replace("lights:\n", lamp).replace(
            "materials:\n", f"materials:\n  lamp: {{albedo: [0, 0, 0], emission: {emission}}}\n")
        return parse_scene(text + lights, ROOT / "scenes" / "inline.yaml")

    both = sc("[4, 4, 4]", point)
    world = load_world(both)
    assert world.lights.entries == 3 and world.lights.count == 2
    # powers: the quad luminance(Le) x area = 4 x 0.25, the point light 4 I (flux / pi)
    np.testing.assert_allclose(world.lights.pmf[2] / world.lights.pmf[:2].sum(), 4.0 / (4 * 0.25), rtol=1e-6)
    spp = 256
    r_both, _ = render(gl, both, spp, 5)
    r_lamp, _ = render(gl, sc("[4, 4, 4]", ""), spp, 6)
    r_point, _ = render(gl, sc("[0, 0, 0]", point), spp, 7)
    n = r_both.image.size
    se = math.sqrt(sum(float(r.variance.mean()) for r in (r_both, r_lamp, r_point)) / n)
    z = (r_both.image.mean() - r_lamp.image.mean() - r_point.image.mean()) / se
    assert abs(z) < 4, z



def test_light_pick_hands_on_its_number_rescaled_within_the_bucket(gl):
    """Issue #23: light sampling picks the entry with u.x of its 2D sample and passes the rest of
    u.x, rescaled to [0, 1) within the entry's cdf bucket, on to the light's own sampling (as
    Mitsuba 3's sample_reuse), so the 2D point stays stratified over all lights together. The
    rest must be (u - c0) / (c1 - c0) and uniform given the pick, for unequal buckets."""
    from .test_materials_util import chi2_test, floats, probe

    lamp = "materials:\n  lamp: {albedo: [0, 0, 0], emission: [4, 4, 4]}\n"
    text = PLANE.replace("{b}", "1").replace("materials:\n", lamp)
    text = text.replace("lights:\n", "  - file: models/quad.obj\n    material: lamp\n"
                        "    transform: {translate: [0, 0, 1.5], rotate_deg: [180, 0, 0], scale: 0.5}\nlights:\n")
    sc = parse_scene(text + "  - {type: point, position: [0.5, 0, 1.0], intensity: [1, 1, 1]}\n",
                     ROOT / "scenes" / "inline.yaml")
    lights = load_world(sc).lights
    assert lights.entries == 3
    n = 1 << 16
    u = ((np.arange(n) + 0.5) / n).astype(np.float32)[:, None]  # exact in float32
    out = probe(gl, "light", u, tbos={"lights": lights.pack()}, light_count=lights.entries)
    rest = floats(out)[:, 2]
    table = lights.pack()
    bounds = np.r_[0.0, table[:2, 1].view(np.float32), 1.0]  # the last bound is +inf in the table
    pick = np.searchsorted(bounds[1:], u[:, 0], side="right")  # the entry whose bucket holds u
    np.testing.assert_array_equal(out[:, 0], table[pick, 0])
    want = (u[:, 0] - bounds[pick]) / (bounds[pick + 1] - bounds[pick])
    np.testing.assert_allclose(rest, want, atol=2e-6)
    assert rest.min() >= 0.0 and rest.max() < 1.0
    for e in range(3):  # uniform given the pick
        r = rest[pick == e]
        p, stat, dof = chi2_test(np.bincount((r * 16).astype(int), minlength=16), np.full(16, r.size / 16))
        assert p > 1e-3, f"entry {e}: chi2 = {stat:.1f} for {dof} dof"


@pytest.mark.parametrize("count", [2, 5, 16])  # 1, 3 and 4 steps (a program each: few)
def test_the_written_out_light_search_picks_what_the_loop_picks(gl, count):
    """glsl/lights.glsl light_pick with its binary search written out for a few lights
    (mcpt/shading/lights.py search_steps, issue #23) returns the entry, pmf and rescaled number of
    the loop, bit for bit, and the entry whose cdf bucket holds u: at every bucket's edges too."""
    from mcpt.shading.lights import search_steps

    from .probes import run_test_probe
    from .test_materials_util import MODE, PROBE_FEATURES

    rng = np.random.default_rng(count)
    pmf = rng.random(count).astype(np.float32) + 0.05
    pmf /= pmf.sum()
    cdf = np.cumsum(pmf, dtype=np.float32)
    cdf[-1] = np.inf  # as mcpt/shading/lights.py packs the last bound
    table = np.zeros((count, 4), np.uint32)
    table[:, 0] = np.arange(count) * 7 + 3  # an entry's reference (a triangle index)
    table[:, 1] = cdf.view(np.uint32)
    table[:, 2] = pmf.view(np.uint32)
    edges = cdf[:-1]
    u = np.concatenate([rng.random(4000, dtype=np.float32), edges, np.nextafter(edges, np.float32(0)),
                        np.nextafter(edges, np.float32(1)), np.float32([0.0, 0.99999994])])
    buf = np.zeros((u.size, 4), np.uint32)
    buf[:, 0] = u.view(np.uint32)
    out = {}
    for steps in (0, search_steps(count)):
        pre = PROBE_FEATURES.preamble().replace("#define MCPT_LIGHT_STEPS 0", f"#define MCPT_LIGHT_STEPS {steps}")
        assert f"#define MCPT_LIGHT_STEPS {steps}" in pre
        key = ("probe_sample", PROBE_FEATURES.key) if steps == 0 else ("probe_sample_steps", steps)
        out[steps] = run_test_probe(gl, "probe_sample.frag", buf, u.size, preamble=pre,
                                    key=key, tbos={"lights": table},
                                    uniforms={"u_mode": MODE["light"], "u_light_count": count}, width=1024)
    assert search_steps(count) == int(np.ceil(np.log2(count)))
    np.testing.assert_array_equal(out[0], out[search_steps(count)])
    pick = np.searchsorted(np.r_[cdf[:-1], np.float32(np.inf)], u, side="right")
    np.testing.assert_array_equal(out[0][:, 0], table[pick, 0])


BAD = [
    ("  - {type: point, position: [0, 0, 1], intensity: [0, 0, 0]}", "lights.0.intensity", "zero"),
    ("  - {type: point, position: [0, 0, 1], intensity: [-1, 1, 1]}", "lights.0.intensity", "greater than or equal"),
    ("  - {type: spot, position: [0, 0, 1], look_at: [0, 0, 0], intensity: [1, 1, 1], cutoff_deg: 10, beam_deg: 20}",
     "lights.0.beam_deg", "exceeds cutoff_deg"),
    ("  - {type: lamp, position: [0, 0, 1]}", "lights.0.type", "point"),
    ("  - {type: point, position: [0, 0, 1], intensity: [1, 1, 1], colour: 2}", "lights.0.colour", "unknown key"),
    ("  - {type: directional, direction: [0, 0, 1], intensity: [1, 1, 1]}", "lights.0.intensity", "has no intensity"),
    ("  - {type: directional, irradiance: [1, 1, 1]}", "lights.0.direction", "needs direction"),
    ("  - {type: spot, position: [0, 0, 1], intensity: [1, 1, 1]}", "lights.0.look_at", "look_at or direction"),
]


@pytest.mark.parametrize(("light", "key", "why"), BAD)
def test_bad_lights_get_one_located_line(light, key, why):
    text = PLANE.replace("{b}", "1") + light
    with pytest.raises(SceneError) as e:
        parse_scene(text, ROOT / "scenes" / "inline.yaml")
    msg = str(e.value)
    assert "\n" not in msg and f"inline.yaml:{text.count(chr(10)) + 1}: {key}" in msg and why in msg, msg


@pytest.mark.parametrize("sampling", ["mis", "nee", "bsdf"])
def test_sun_disk_on_a_plane_gives_the_same_irradiance(gl, sampling):
    """A sun disk of radiance E / (pi sin^2 alpha) fully above the plane's horizon gives the plane
    irradiance pi L sin^2(alpha) cos(theta) = E cos(theta): the delta sun's picture, within noise,
    by light sampling, by BSDF sampling (rays escaping into the disk) and by both."""
    sc = scene("  - {type: directional, direction: [0, -0.5, -1], irradiance: [2, 2, 2], angular_diameter_deg: 20}")
    res, feats = render(gl, sc, 256, 9, sampling=sampling)
    assert feats.defines()["MCPT_LIGHT_SUN"] == 1 and feats.defines()["MCPT_LIGHT_DIRECTIONAL"] == 0
    want = RHO / math.pi * 2.0 / math.sqrt(1.25)
    se = math.sqrt(float(res.variance.mean()) / res.image.size) + 1e-6 * want
    assert abs(res.image.mean() - want) / se < 4, (res.image.mean(), want, se)


# --- chi-square of the new sampling routines on the real GLSL (tests/glsl/probe_sample.frag) ---

def test_sun_cone_sampling_is_uniform_in_its_cap(gl):
    """sample_cone about a tilted axis: every direction inside the cap of cos half-angle 0.95,
    uniform in (cos theta, phi) about the axis, i.e. its pdf 1 / (2 pi (1 - cos_max))."""
    from .test_materials_util import chi2_test, floats, probe, uniform_numbers

    n, cos_max = 1 << 18, 0.95
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    w = floats(probe(gl, "cone", uniform_numbers(n, 2, seed=31), wo=tuple(axis), alpha=cos_max))[:, :3]
    w = w.astype(np.float64)
    np.testing.assert_allclose(np.linalg.norm(w, axis=1), 1.0, atol=1e-5)
    t = np.cross(axis, [1.0, 0.0, 0.0])
    t /= np.linalg.norm(t)
    b = np.cross(axis, t)
    c = w @ axis
    assert c.min() >= cos_max - 1e-6
    phi = np.arctan2(w @ b, w @ t)
    h, _, _ = np.histogram2d(c, phi, bins=[16, 32], range=[[cos_max, 1.0], [-np.pi, np.pi]])
    p, stat, dof = chi2_test(h, np.full(h.shape, n / h.size))
    assert p > 1e-3, f"chi2 = {stat:.1f} for {dof} dof, p = {p:.3g}"


def test_environment_sphere_sampling_is_uniform(gl):
    from .test_materials_util import chi2_test, floats, probe, sphere_histogram, uniform_numbers

    n = 1 << 18
    w = floats(probe(gl, "sphere", uniform_numbers(n, 2, seed=32)))[:, :3].astype(np.float64)
    np.testing.assert_allclose(np.linalg.norm(w, axis=1), 1.0, atol=1e-5)
    h = sphere_histogram(w, 16, 32)
    p, stat, dof = chi2_test(h, np.full(h.shape, n / h.size))
    assert p > 1e-3, f"chi2 = {stat:.1f} for {dof} dof, p = {p:.3g}"


@pytest.mark.parametrize(("name", "kinds"), [
    ("cornell-box", {"area"}), ("lamps", {"point", "spot"}), ("sky", {"env", "envmap"})])
def test_shipped_scenes_compile_only_their_light_types(name, kinds):
    """The light code a program holds is the scene's: the Cornell box's has no punctual, sun or
    environment code (its paths/s and pixels stay main's), lamps.yaml no area or sky code."""
    from mcpt.gpu.shader import Source

    world = load_world(parse_scene((ROOT / "scenes" / f"{name}.yaml").read_text(), ROOT / "scenes" / f"{name}.yaml"))
    text = Source("pathtrace.frag", for_world(world).preamble()).text
    marks = {"area": "void area_sample", "point": "void punctual_sample", "spot": "float spot_falloff",
             "sun": "void sun_escaped", "env": "void env_escaped", "envmap": "vec3 env_radiance_pdf"}
    for kind, mark in marks.items():
        assert (mark in text) == (kind in kinds or (kind == "point" and "spot" in kinds)), (name, kind)


def test_more_sun_disks_than_the_shader_holds_are_refused_with_their_line():
    from mcpt.errors import McptError

    sun = "  - {type: directional, direction: [0, 0, -1], irradiance: [1, 1, 1], angular_diameter_deg: 1}\n"
    with pytest.raises(McptError, match=r"inline.yaml:\d+: lights: 5 lights with an angular diameter; "
                                        r"mcpt takes at most 4"):
        from mcpt.gpu.pack import pack

        world = load_world(scene(sun * 5))
        pack(world, for_world(world))


def test_info_lists_every_light_with_its_pick_probability():
    from mcpt.shading.lights import describe_lights

    sc = scene("  - {type: point, position: [0, 0, 1], intensity: [1, 1, 1]}\n"
               "  - {type: directional, direction: [0, 0, -1], irradiance: [1, 1, 1]}\n")
    world = load_world(sc)
    info = describe_lights(world.lights, sc)
    assert info["entries"] == 2 and info["area (emissive triangles)"] == 0
    p0 = float(info["point 0"].rsplit(" ", 1)[1])
    p1 = float(info["directional 1"].rsplit(" ", 1)[1])
    assert p0 + p1 == pytest.approx(1.0, abs=1e-5) and p0 == pytest.approx(float(world.lights.pmf[0]), rel=1e-5)

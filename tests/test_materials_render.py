"""Materials end to end (issue #3): furnaces, estimator agreement, golden images.

Every render here goes through the real path tracer (glsl/pathtrace.frag) on small images."""

import os

import numpy as np
import pytest

from mcpt.gpu.features import for_world
from mcpt.scene import Scene, load_scene, parse_scene
from mcpt.shapes.world import load_world

from .conftest import ROOT
from .draw import render as draw
from .test_materials_util import renderer

SCENES = ROOT / "scenes"
SEED_OFFSET = int(os.environ.get("MCPT_TEST_SEED", "0"))  # vary to check the tests' false-alarm rate


def render(gl, scene, spp, seed, *, bounces=None, variance=True, **flags):
    world = load_world(scene)
    feats = for_world(world, bounces=bounces, variance=variance, **flags)
    r = renderer(gl, world, feats)
    try:
        return draw(r, spp, seed + SEED_OFFSET), feats
    finally:
        r.release()


def furnace(material: str, *, bounces=8, res=16) -> Scene:
    text = f"""
camera: {{position: [0, 0, 0], look_at: [0, 0, -1], vfov_deg: 60, resolution: [{res}, {res}]}}
render: {{bounces: {bounces}}}
materials:
  m: {material}
meshes:
  - file: furnace/sphere_inward.obj
    material: m
"""
    return parse_scene(text, SCENES / "inline.yaml")


def test_white_mirror_furnace_is_exact(gl):
    """An emitting white mirror enclosure (Le = 1, F0 = 1): each of the bounces + 1 vertices adds
    exactly 1, in every sample, with roulette off."""
    res, f = render(gl, furnace("{type: conductor, albedo: [1, 1, 1], emission: [1, 1, 1]}"), 2, 1,
                    russian_roulette=False)
    assert f.uses.conductor and not f.uses.microfacet
    np.testing.assert_array_equal(res.image, 9.0)


def test_white_plastic_furnace_matches_the_analytic_value(gl):
    """A white plastic reflects all light: Le (bounces + 1) as for the mirror, within noise."""
    res, f = render(gl, furnace("{type: plastic, albedo: [1, 1, 1], emission: [1, 1, 1]}"), 32, 2)
    assert f.uses.plastic
    img, var = res.image.astype(np.float64), res.variance.astype(np.float64)
    se = np.sqrt(var.mean() / img.size * 3)  # pooled: every pixel sees the same statistics
    assert res.dropped_samples == 0
    assert abs(img.mean() - 9.0) < 4 * se + 1e-4, (img.mean(), se)


@pytest.mark.parametrize("alpha", [0.1, 0.5])
def test_rough_white_conductor_furnace_loses_but_never_gains(gl, alpha):
    res, _ = render(gl, furnace(f"{{type: conductor, albedo: [1, 1, 1], roughness: {alpha}, "
                                "emission: [1, 1, 1]}"), 16, 3)
    img = res.image.astype(np.float64)
    se = np.sqrt(res.variance.astype(np.float64).mean() / img.size * 3)
    assert img.mean() < 9.0 + 4 * se
    # Directional albedo ~0.98 at alpha 0.1, ~0.7 at alpha 0.5 (test_materials.py): L = sum e^k.
    assert img.mean() > (8.0 if alpha < 0.2 else 2.5)


def test_glass_sphere_in_a_uniform_emitter_is_invisible(gl):
    """Glass only redirects light: the sphere vanishes in a uniform emitter. What the bounce limit
    cuts off (paths trapped near the silhouette by total internal reflection) is the only loss:
    measured 2e-4 at 200 bounces with smooth normals. (A flat-faceted sphere traps more: its facets
    break the symmetry that keeps a perfect sphere's internal angles below the critical angle.)"""
    res, f = render(gl, load_scene(SCENES / "furnace-glass.yaml"), 64, 4)
    assert f.uses.dielectric and f.smooth_normals
    img, var = res.image.astype(np.float64), res.variance.astype(np.float64)
    z = (img - 1.0) / np.sqrt(np.maximum(var, 1e-12))
    assert res.dropped_samples == 0
    assert abs(img.mean() - 1.0) < 1e-3
    assert (np.abs(z) < 4.0).mean() > 0.995 and np.abs(z).max() < 6.0


# ----------------------------------------------------------------------------------------------
# light sampling, BSDF sampling and MIS estimate the same thing


def _smoothed(v):
    """Per-pixel variance, raised to its 3x3 neighbourhood mean where that is larger: a pixel whose
    few samples missed a rare large value has an underestimated variance, its neighbours less so."""
    p = np.pad(v, ((1, 1), (1, 1), (0, 0)), mode="edge")
    mean = sum(p[i:i + v.shape[0], j:j + v.shape[1]] for i in range(3) for j in range(3)) / 9.0
    return np.maximum(v, mean)


def agree(a, b, spp):
    """Per-pixel z-test of two independent renders (mean, variance of the mean), with Mitsuba's
    variance floor (per-sample variance >= 1e-4), plus 4x4-block and whole-image tests."""
    (x, vx), (y, vy) = a, b
    floor = 1e-4 / spp
    z = (x - y) / np.sqrt(np.maximum(_smoothed(vx), floor) + np.maximum(_smoothed(vy), floor))
    h, w = x.shape[0] // 4 * 4, x.shape[1] // 4 * 4

    def blocks(img, var=False):
        s = img[:h, :w].reshape(h // 4, 4, w // 4, 4, 3).sum(axis=(1, 3))
        return s / 256.0 if var else s / 16.0

    zb = (blocks(x) - blocks(y)) / np.sqrt(blocks(vx, True) + blocks(vy, True) + 1e-20)
    zg = (x.mean() - y.mean()) / (np.sqrt(vx.sum() + vy.sum()) / x.size)
    return np.abs(z), np.abs(zb), abs(zg)


def four_spheres():
    """A Cornell box with a mirror, a glass, a rough metal and a plastic sphere under a large
    light (the ceiling light scaled 2.6x, same power), so BSDF sampling alone finds it often
    enough for a per-pixel test at a few hundred samples."""
    text = (SCENES / "cornell-spheres.yaml").read_text()
    text = text[:text.index("  - file: models/icosphere.obj")]
    text = text.replace("    emission: [18.387, 13.9873, 6.75357]", "    emission: [2.72, 2.07, 1.0]")
    text = text.replace("  - file: cornell/light.obj\n    material: light",
                        "  - file: cornell/light.obj\n    material: light\n    transform: {scale: [2.6, 1.0, 2.6]}")
    text = text.replace("meshes:", (
        "  metal: {type: conductor, albedo: [0.9, 0.6, 0.3], roughness: 0.15, smooth_normals: true}\n"
        "  plastic: {type: plastic, albedo: [0.2, 0.4, 0.8], smooth_normals: true}\n"
        "meshes:"))
    for mat, pos in (("mirror", "-0.5, -0.7, -0.4"), ("glass", "0.5, -0.7, 0.3"),
                     ("metal", "0.45, -0.7, -0.5"), ("plastic", "-0.45, -0.7, 0.35")):
        text += f"  - {{file: models/icosphere.obj, material: {mat}, transform: {{scale: 0.3, translate: [{pos}]}}}}\n"
    return parse_scene(text, SCENES / "four-spheres.yaml").with_overrides(resolution=(24, 24), bounces=4)


def test_nee_bsdf_and_mis_agree_on_every_material(gl):
    scene = four_spheres()
    spp = 192
    out = {}
    for seed, mode in enumerate(("mis", "nee", "bsdf")):
        res, f = render(gl, scene, spp, 100 + seed, sampling=mode)
        u = f.uses
        assert u.conductor and u.microfacet and u.dielectric and u.plastic and u.diffuse
        # the switch picks the estimator; the scene's uses stay the same
        assert (f.nee, f.mis) == {"mis": (True, True), "nee": (True, False), "bsdf": (False, False)}[mode]
        assert res.dropped_samples == 0
        out[mode] = (res.image.astype(np.float64), res.variance.astype(np.float64))
    for a, b in (("mis", "nee"), ("mis", "bsdf"), ("nee", "bsdf")):
        z, zb, zg = agree(out[a], out[b], spp)
        # 1728 pixel-channels: Gaussian noise alone gives max |z| ~ 4; the BSDF-only image has
        # heavier tails (caustics through the glass), hence the margins.
        assert z.max() < 5.5 and (z > 4).mean() < 0.005, (a, b, z.max(), (z > 4).mean())
        assert zb.max() < 4.5, (a, b, zb.max())
        assert zg < 4.0, (a, b, zg)


def test_mis_beats_light_and_bsdf_sampling_on_the_glossy_scene(gl):
    """scenes/mis-glossy.yaml: a large light seen in smooth metal (left half of the floor: hard
    for light sampling) and a small one in rough metal (right half: hard for BSDF sampling).
    The same seed for all three: every mode draws the same BSDF directions (the random-number
    layout does not depend on the mode), so a rare caustic path, which all three find alike,
    cannot make one mode look worse by luck."""
    scene = load_scene(SCENES / "mis-glossy.yaml").with_overrides(resolution=(48, 32))
    spp = 64
    out = {}
    for mode in ("mis", "nee", "bsdf"):
        res, _ = render(gl, scene, spp, 200, sampling=mode)
        out[mode] = (res.image.astype(np.float64), res.variance.astype(np.float64))
    var = {m: out[m][1] for m in out}
    left, right = np.s_[16:, :24], np.s_[16:, 24:]
    assert var["mis"][left].sum() < 0.2 * var["nee"][left].sum()
    assert var["mis"][right].sum() < 0.2 * var["bsdf"][right].sum()
    for region in (left, right, np.s_[:, :]):
        assert var["mis"][region].sum() < 1.1 * min(var["nee"][region].sum(), var["bsdf"][region].sum())
    for a, b in (("mis", "nee"), ("mis", "bsdf")):
        assert agree(out[a], out[b], spp)[2] < 4.0


def test_absorbing_glass_transmits_beer_lambert(gl):
    """Rays through the centre of an absorbing glass ball (radius 0.1) in a uniform emitter: at
    normal incidence F = ((n - 1) / (n + 1))^2 and each crossing keeps T = color (the absorption
    distance is the diameter), so L = F + (1 - F)^2 T / (1 - F T) (light bouncing inside adds the
    geometric series)."""
    text = """
camera: {position: [0, 0, 0.95], look_at: [0, 0, 0], vfov_deg: 0.4, resolution: [16, 16]}
render: {bounces: 32}
materials:
  enclosure: {albedo: [0, 0, 0], emission: [1, 1, 1]}
  glass: {type: dielectric, ior: 1.5, smooth_normals: true,
          absorption: {color: [0.5, 0.7, 0.9], distance: 0.2}}
meshes:
  - {file: furnace/sphere_inward.obj, material: enclosure}
  - {file: models/icosphere.obj, material: glass, transform: {scale: 0.1}}
"""
    res, f = render(gl, parse_scene(text, SCENES / "inline.yaml"), 256, 5)
    assert f.uses.absorption
    F = (0.5 / 2.5) ** 2
    T = np.array([0.5, 0.7, 0.9])
    want = F + (1 - F) ** 2 * T / (1 - F * T)
    got = res.image.reshape(-1, 3).astype(np.float64).mean(axis=0)
    se = np.sqrt(res.variance.reshape(-1, 3).astype(np.float64).sum(axis=0)) / (res.image.size / 3)
    assert np.all(np.abs(got - want) < 4 * se + 1e-3), (got, want, se)

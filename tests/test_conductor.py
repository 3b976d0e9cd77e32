"""Conductor Fresnel modes and sidedness (issue #13): the exact conductor Fresnel against an
independent complex-arithmetic numpy twin, ``fresnel: none`` in white furnaces, GGX energy against
quadrature, one-sided surfaces seen from behind, and the scene keys. Chi-square tests of the new
variants' sampling are in test_sampling.py (BSDF_CASES)."""

import math

import numpy as np
import pytest

from mcpt.gpu.features import for_world
from mcpt.scene import SceneError, parse_scene
from mcpt.shading.materials import FLAG_ONE_SIDED, FRESNEL, FRESNEL_SHIFT, fresnel_dielectric
from mcpt.shading.metals import METALS
from mcpt.shapes.world import load_world

from .conftest import ROOT
from .test_materials_render import furnace, render
from .test_materials_util import floats, probe, sphere_grid, uniform_numbers

SPHERE = ROOT / "scenes" / "models" / "icosphere.obj"
QUAD = ROOT / "scenes" / "models" / "quad.obj"
NONE_FLAGS = FRESNEL["none"] << FRESNEL_SHIFT
COMPLEX_FLAGS = FRESNEL["conductor"] << FRESNEL_SHIFT


def fr_complex(cos_i, eta, k):
    """pbrt-v4's FrComplex in numpy complex128: 0.5 (|r_par|^2 + |r_perp|^2) for the complex
    index eta + i k (Snell's law with a complex cosine, principal square root)."""
    n = np.asarray(eta, np.float64) + 1j * np.asarray(k, np.float64)
    c = np.clip(np.asarray(cos_i, np.float64), 0.0, 1.0)
    sin2_t = (1.0 - c**2) / n**2
    cos_t = np.sqrt(1.0 - sin2_t + 0j)
    r_par = (n * c - cos_t) / (n * c + cos_t)
    r_perp = (c - n * cos_t) / (c + n * cos_t)
    return 0.5 * (np.abs(r_par) ** 2 + np.abs(r_perp) ** 2)


def _u(**kw):
    base = dict(type="conductor", albedo=(1, 1, 1), alpha=0.0, ior=1.5, fdr_int=0.0, wo=(0, 0, 1), front=1)
    base.update(kw)
    return base


def _complex(metal=None, eta=None, k=None, **kw):
    eta, k = METALS[metal] if metal else (eta, k)
    return _u(flags=COMPLEX_FLAGS, eta=eta, k=k, **kw)


# ----------------------------------------------------------------------------------------------
# the Fresnel factor itself


def test_conductor_fresnel_matches_complex_arithmetic(gl):
    """GLSL (real arithmetic, Moeller's form) against numpy FrComplex: the presets and 300 indices at
    41 cosines each (0 and 1 included), and 10^5 random (cos, eta, k), eta in [0.03, 6], k in
    [0, 10]. Near total internal reflection (eta < sin, k ~ 0) the textbook form loses 1e-4 to
    cancellation; the shader's rearrangement keeps the error at float32 rounding (measured < 5e-7)."""
    rng = np.random.default_rng(13)
    etas = np.concatenate([np.array([m[0] for m in METALS.values()]).reshape(-1),
                           rng.uniform(0.03, 6.0, 300 - 3 * len(METALS))])
    ks = np.concatenate([np.array([m[1] for m in METALS.values()]).reshape(-1),
                         rng.uniform(0.0, 10.0, 300 - 3 * len(METALS))])
    ks[-20:] = 0.0  # k = 0: a dielectric, below and above eta = 1 (total internal reflection)
    ks[-40:-20] = rng.uniform(0.0, 1e-3, 20)  # almost a dielectric
    cos = np.concatenate([[0.0, 1e-4, 1.0], np.linspace(0.0, 1.0, 38)])
    C, idx = np.meshgrid(cos, np.arange(300), indexing="ij")
    grid = np.stack([C.ravel(), etas[idx.ravel()], ks[idx.ravel()]], 1)
    rand = np.stack([rng.uniform(0, 1, 100_000), rng.uniform(0.03, 6.0, 100_000), rng.uniform(0, 10, 100_000)], 1)
    items = np.concatenate([grid, rand]).astype(np.float32)
    out = floats(probe(gl, "fresnel_conductor", items)).astype(np.float64)
    assert (out[:, 0] == out[:, 1]).all() and (out[:, 0] == out[:, 2]).all()
    got = out[:, 0]
    want = fr_complex(items[:, 0], items[:, 1], items[:, 2])
    err = np.abs(got - want)
    assert err.max() < 2e-6, (err.max(), items[err.argmax()])
    assert np.all((got >= 0) & (got <= 1))
    # k = 0, eta > 1 is a dielectric: the same as the host's dielectric Fresnel.
    c, e, k = items[:, 0].astype(np.float64), items[:, 1].astype(np.float64), items[:, 2]
    d = (k == 0) & (e > 1)
    assert d.sum() > 300
    np.testing.assert_allclose(got[d], fresnel_dielectric(c[d], e[d]), atol=2e-6)


def test_metal_presets_are_physical():
    """Normal-incidence reflectance ((n-1)^2 + k^2) / ((n+1)^2 + k^2) of the presets against the
    handbook values of the bulk metals (visible, linear RGB; gold and copper red > green > blue)."""
    r0 = {m: ((np.array(e) - 1) ** 2 + np.array(k) ** 2) / ((np.array(e) + 1) ** 2 + np.array(k) ** 2)
          for m, (e, k) in METALS.items()}
    assert set(METALS) >= {"Au", "Ag", "Cu", "Al", "Cr"}
    assert r0["Au"][0] > 0.9 and r0["Au"][0] > r0["Au"][1] > r0["Au"][2] + 0.3
    assert r0["Cu"][0] > 0.9 and r0["Cu"][0] > r0["Cu"][1] > r0["Cu"][2]
    assert r0["Ag"].min() > 0.9 and r0["Al"].min() > 0.9
    assert 0.55 < r0["Cr"].min() and r0["Cr"].max() < 0.75


# ----------------------------------------------------------------------------------------------
# the BSDF with each mode


@pytest.mark.parametrize("wo", [(0.0, 0.0, 1.0), (0.6, 0.0, 0.8), (0.995, 0.0, math.sqrt(1 - 0.995**2))])
def test_fresnel_none_mirror_weight_is_the_reflectance_exactly(gl, wo):
    for s in ((1.0, 1.0, 1.0), (0.9, 0.9, 0.9), (0.2, 0.5, 1.0)):
        out = probe(gl, "weight", uniform_numbers(1024, 2, 1), **_u(flags=NONE_FLAGS, albedo=s, wo=wo))
        assert (out[:, 3] == 3).all()  # valid, delta
        np.testing.assert_array_equal(floats(out)[:, :3], np.broadcast_to(np.float32(s), (1024, 3)))


@pytest.mark.parametrize("metal", ["Au", "Cu", "Cr"])
def test_complex_mirror_weight_is_the_exact_fresnel_times_the_scale(gl, metal):
    s = (0.9, 0.8, 1.0)
    for c in (1.0, 0.7, 0.2, 0.03):
        wo = (math.sqrt(1 - c * c), 0.0, c)
        w = floats(probe(gl, "weight", uniform_numbers(64, 2, 2), **_complex(metal, albedo=s, wo=wo)))[:, :3]
        eta, k = METALS[metal]
        want = np.asarray(s) * fr_complex(np.float32(c), np.asarray(eta, np.float32), np.asarray(k, np.float32))
        np.testing.assert_allclose(w, np.broadcast_to(want, w.shape), rtol=1e-4, atol=2e-6)


def test_schlick_scale_multiplies_the_lobe(gl):
    wo = (0.6, 0.0, 0.8)
    base = floats(probe(gl, "weight", uniform_numbers(64, 2, 3), **_u(albedo=(0.9, 0.6, 0.3), wo=wo)))
    scaled = floats(probe(gl, "weight", uniform_numbers(64, 2, 3),
                          **_u(albedo=(0.9, 0.6, 0.3), scale=(0.5, 0.25, 1.0), wo=wo)))
    np.testing.assert_allclose(scaled[:, :3], base[:, :3] * np.float32([0.5, 0.25, 1.0]), rtol=1e-6)


def _ggx_energy(wo, alpha, fresnel, n_theta=256, ires=4):
    """Directional albedo int f |cos| dwi of a GGX conductor by quadrature in numpy (textbook D,
    height-correlated Smith G2), Fresnel(wi.h) given as a function of the cosine (RGB)."""
    grid = sphere_grid(n_theta, 2 * n_theta, ires)
    wi = grid[grid[:, 2] > 0]
    wo = np.broadcast_to(np.asarray(wo, np.float64), wi.shape)
    lam = lambda w: (-1.0 + np.sqrt(1.0 + alpha**2 * (1.0 - w[:, 2] ** 2) / w[:, 2] ** 2)) / 2.0  # noqa: E731
    h = wo + wi
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    d = alpha**2 / (np.pi * (h[:, 2] ** 2 * (alpha**2 - 1.0) + 1.0) ** 2)
    fcos = fresnel((wi * h).sum(1)) * (d / (4.0 * wo[:, 2] * (1.0 + lam(wo) + lam(wi))))[:, None]
    return fcos.sum(0) * (4.0 * np.pi / grid.shape[0])


@pytest.mark.parametrize("alpha", [0.3, 0.6, 1.0])
def test_ggx_fresnel_none_energy_is_the_single_scattering_albedo(gl, alpha):
    """With F = 1 the mean sample weight is GGX's single-scattering directional albedo, whose
    deficit from 1 is the known loss of multiple scattering between microfacets (e.g. 0.307 at
    normal incidence for alpha 1, Heitz 2016 / Kulla & Conty 2017), computed by quadrature."""
    for wo in [(0.0, 0.0, 1.0), (0.6, 0.0, 0.8), (0.0, 0.95, math.sqrt(1 - 0.95**2))]:
        w = floats(probe(gl, "weight", uniform_numbers(1 << 17, 2, int(alpha * 10)),
                         **_u(flags=NONE_FLAGS, alpha=alpha, wo=wo)))[:, 0].astype(np.float64)
        e = _ggx_energy(wo, alpha, lambda c: np.ones((c.size, 3)))[0]
        se = w.std() / math.sqrt(w.size)
        assert abs(w.mean() - e) < 4 * se + 2e-3, (alpha, wo, w.mean(), e)
        assert e < 1.0 and (w <= 1.0 + 1e-6).all()


def test_ggx_complex_energy_matches_quadrature(gl):
    wo = (0.6, 0.0, 0.8)
    eta, k = METALS["Au"]
    w = floats(probe(gl, "weight", uniform_numbers(1 << 17, 2, 21),
                     **_complex("Au", alpha=0.4, wo=wo)))[:, :3].astype(np.float64)
    e = _ggx_energy(wo, 0.4, lambda c: fr_complex(c[:, None], eta, k))
    se = w.std(0) / math.sqrt(len(w))
    assert np.all(np.abs(w.mean(0) - e) < 4 * se + 2e-3), (w.mean(0), e)
    # In the mirror direction the half vector is the normal, wi.h = 0.8: f_Au = Fr(0.8) f_none.
    wi = np.array([[-0.6, 0.0, 0.8]], np.float32)
    f_au = floats(probe(gl, "eval", wi, **_complex("Au", alpha=0.4, wo=wo)))[0, :3]
    f_1 = floats(probe(gl, "eval", wi, **_u(flags=NONE_FLAGS, alpha=0.4, wo=wo)))[0, :3]
    np.testing.assert_allclose(f_au, f_1 * fr_complex(0.8, eta, k), rtol=2e-4)


# ----------------------------------------------------------------------------------------------
# rendered: furnaces and sidedness


def test_fresnel_none_white_furnace_is_exact(gl):
    """`fresnel: none`, reflectance 1, emitting 1: every one of the bounces + 1 vertices adds
    exactly 1 in every sample (roulette off); with reflectance 0.9 the geometric series."""
    res, f = render(gl, furnace("{type: conductor, fresnel: none, specular_reflectance: [1, 1, 1], "
                                "emission: [1, 1, 1]}"), 2, 1, russian_roulette=False)
    assert f.uses.conductor and not f.uses.fresnel_complex and f.material_texels == 4
    np.testing.assert_array_equal(res.image, 9.0)
    res, _ = render(gl, furnace("{type: conductor, fresnel: none, specular_reflectance: [0.9, 0.9, 0.9], "
                                "emission: [1, 1, 1]}"), 2, 1, russian_roulette=False)
    np.testing.assert_allclose(res.image, (1 - 0.9**9) / (1 - 0.9), rtol=1e-6)


def test_complex_mirror_furnace_is_the_fresnel_series(gl):
    """A silver mirror enclosure seen from its centre: rays meet the (faceted) sphere near normal
    incidence, so each bounce keeps F(~1) of silver: L = sum F^j, F from the numpy twin. The
    facets tilt the rays a little more at each bounce: the bound allows cosines down to 0.9."""
    res, f = render(gl, furnace("{type: conductor, metal: Ag, emission: [1, 1, 1]}", res=8), 2, 1,
                    russian_roulette=False)
    assert f.uses.fresnel_complex and f.material_texels == 5
    eta, k = METALS["Ag"]
    lo, hi = fr_complex(0.9, eta, k), fr_complex(1.0, eta, k)
    img = res.image.reshape(-1, 3).astype(np.float64)
    series = lambda F: (1 - F**9) / (1 - F)  # noqa: E731
    assert np.all(img >= series(np.minimum(lo, hi)) - 1e-4) and np.all(img <= series(np.maximum(lo, hi)) + 1e-4)


def _quad_scene(material: str, back: bool):
    """Camera at the centre of a uniformly emitting black enclosure (radiance 1) looking at a
    small quad: its front side, or its back (the quad turned by 180 degrees)."""
    text = f"""
camera: {{position: [0, 0, 0], look_at: [0, 0, -1], vfov_deg: 60, resolution: [8, 8]}}
render: {{bounces: 2}}
materials:
  sky: {{albedo: [0, 0, 0], emission: [1, 1, 1]}}
  m: {material}
meshes:
  - file: {ROOT / 'scenes' / 'furnace' / 'sphere_inward.obj'}
    material: sky
  - file: {QUAD}
    material: m
    transform: {{scale: 0.3, rotate_deg: [0, {180 if back else 0}, 0], translate: [0, 0, -0.5]}}
"""
    return parse_scene(text, ROOT / "scenes" / "inline.yaml")


@pytest.mark.parametrize("two_sided", [True, False])
@pytest.mark.parametrize("back", [False, True])
def test_one_sided_surface_is_black_from_behind(gl, two_sided, back):
    mat = f"{{type: conductor, fresnel: none, two_sided: {str(two_sided).lower()}}}"
    res, f = render(gl, _quad_scene(mat, back), 2, 5)
    assert f.uses.one_sided == (not two_sided)
    centre = res.image[3:5, 3:5]  # the quad covers the middle pixels
    corner = res.image[0, 0]      # the enclosure
    np.testing.assert_array_equal(corner, 1.0)
    np.testing.assert_array_equal(centre, 0.0 if (back and not two_sided) else 1.0)


def test_one_sided_diffuse_and_plastic_back_is_black(gl):
    for mat in ("{albedo: [1, 1, 1], two_sided: false}", "{type: plastic, albedo: [1, 1, 1], two_sided: false}"):
        res, _ = render(gl, _quad_scene(mat, True), 4, 6)
        np.testing.assert_array_equal(res.image[3:5, 3:5], 0.0)
        res, _ = render(gl, _quad_scene(mat, False), 64, 6)
        assert abs(res.image[3:5, 3:5].mean() - 1.0) < 0.05  # white under radiance 1: 1 on average


# ----------------------------------------------------------------------------------------------
# scene keys and the material table


def _mat(material: str):
    text = f"""
camera: {{position: [0, 0, 3.9], look_at: [0, 0, 0], vfov_deg: 39.3, resolution: [8, 8]}}
materials:
  m: {material}
  lamp: {{emission: [1, 1, 1]}}
meshes:
  - {{file: {SPHERE}, material: m}}
  - {{file: {QUAD}, material: lamp, transform: {{translate: [0, 0, 3]}}}}
"""
    return parse_scene(text, ROOT / "scenes" / "inline.yaml")


def _err(material: str) -> str:
    with pytest.raises(SceneError) as e:
        _mat(material)
    return str(e.value)


def test_conductor_keys_are_validated():
    assert "needs eta and k" in _err("{type: conductor, fresnel: conductor}")
    assert "needs eta and k" in _err("{type: conductor, eta: [0.2, 0.4, 1.4]}")
    assert "metal or eta and k, not both" in _err("{type: conductor, metal: Au, eta: [1, 1, 1], k: [1, 1, 1]}")
    assert "parameter of fresnel: conductor, not none" in _err("{type: conductor, fresnel: none, metal: Au}")
    assert "specular_reflectance, not albedo" in _err("{type: conductor, fresnel: none, albedo: [1, 1, 1]}")
    assert "albedo_texture (F0)" in _err("{type: conductor, specular_reflectance: "
                                         + str(ROOT / "scenes" / "models" / "checker-cube" / "checker.png") + "}")
    assert "Au" in _err("{type: conductor, metal: Unobtainium}")
    assert "diffuse material has no metal" in _err("{metal: Au}")
    assert "dielectric material has no two_sided" in _err("{type: dielectric, two_sided: false}")
    assert "greater than 0" in _err("{type: conductor, eta: [0, 1, 1], k: [1, 1, 1]}")


def test_material_table_carries_the_fresnel_modes():
    gold = load_world(_mat("{type: conductor, metal: Au, specular_reflectance: [0.5, 0.6, 0.7]}"))
    mt = gold.materials
    i = mt.names.index("m")
    assert mt.fresnel[i] == "conductor"  # implied by metal
    f = for_world(gold)
    assert f.uses.fresnel_complex and f.defines()["MCPT_FRESNEL_COMPLEX"] == 1 and f.material_texels == 5
    from mcpt.gpu.pack import pack

    buf = pack(gold, f).buffers["materials"].reshape(-1, 5, 4)[i]
    np.testing.assert_array_equal(buf[0, :3].view(np.float32), np.float32([0.5, 0.6, 0.7]))  # the scale
    assert (buf[2, 3] >> FRESNEL_SHIFT) & 3 == FRESNEL["conductor"] and not buf[2, 3] & FLAG_ONE_SIDED
    np.testing.assert_array_equal(buf[3, :3].view(np.float32), np.float32(METALS["Au"][0]))
    np.testing.assert_array_equal(buf[4, :3].view(np.float32), np.float32(METALS["Au"][1]))
    # Schlick and none need no fifth texel and no complex code; a one-sided diffuse needs texel 2.
    for text, texels in (("{type: conductor, fresnel: none}", 4), ("{type: conductor}", 4),
                         ("{two_sided: false}", 4), ("{}", 2)):
        f = for_world(load_world(_mat(text)))
        assert f.material_texels == texels and not f.uses.fresnel_complex, text
    assert for_world(load_world(_mat("{two_sided: false}"))).uses.one_sided


def test_specular_reflectance_forms():
    checker = ROOT / "scenes" / "models" / "checker-cube" / "checker.png"
    assert _mat("{type: conductor, fresnel: none, specular_reflectance: 0.9}").materials["m"].specular_reflectance \
        == (0.9, 0.9, 0.9)
    assert "item 0: Input should be less than or equal to 1" in _err(
        "{type: conductor, fresnel: none, specular_reflectance: [2, 1, 1]}")
    assert "texture file not found" in _err("{type: conductor, fresnel: none, specular_reflectance: nope.png}")
    # An image as the lobe scale: it takes the albedo slot, which the shader's texture lookup fills.
    world = load_world(_mat("{type: conductor, metal: Cu, "
                            f"specular_reflectance: {{file: {checker}, filter: nearest}}}}"))
    mt = world.materials
    i = mt.names.index("m")
    assert mt.texture[i] == 0 and len(world.textures) == 1 and world.textures[0].filter == "nearest"
    assert for_world(world).textures and world.uvs is not None
    np.testing.assert_allclose(mt.albedo[i], world.textures[0].mean_linear())

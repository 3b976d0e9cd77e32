"""KHR_materials_ior and KHR_materials_specular on glTF's metal-rough material (issue #21 item 5;
glsl/bsdf_metalrough.glsl under MCPT_METALROUGH_SPECULAR, mcpt/shading/metalrough.py): the real GLSL
against the float64 twin (value and pdf) and the twin against the extensions' own text written here,
chi-square of the sampling with the new lobe weights, energy against quadrature (sampled and rendered),
the glTF and YAML mappings, bad values, and the default material's program and pixels unchanged."""

import json
import logging
import math
import zlib

import numpy as np
import pytest

from mcpt.gpu.features import Features, for_world
from mcpt.scene import load_scene
from mcpt.shading import metalrough
from mcpt.shading import microfacet as MF
from mcpt.shapes.world import load_world

from .test_conductor import _err, _mat
from .test_material_input import gltf_scene, lacking, one_error, render
from .test_materials_util import (
    cell_probabilities,
    chi2_test,
    floats,
    probe,
    sidak,
    sphere_grid,
    sphere_histogram,
    uniform_numbers,
)

N = 1 << 18
NT, NP, IRES = 32, 64, 12
BASE = (0.8, 0.5, 0.2)
# (metallic, roughness, ior, specularFactor, specularColorFactor)
CASES = [(0.0, 0.5, 1.0, 0.5, (1.0, 0.2, 0.2)),
         (0.3, 0.3, 2.5, 1.0, (2.0, 1.0, 0.5)),
         (0.0, 0.6, 0.0, 0.3, (0.5, 0.5, 1.0)),
         (0.0, 0.4, 1.33, 0.0, (1.0, 1.0, 1.0)),
         (0.5, 0.8, 1.7, 0.8, (1.0, 1.0, 1.0))]
IDS = [f"m{c[0]}-r{c[1]}-ior{c[2]}-s{c[3]}" for c in CASES]
ALPHA = sidak(0.01, len(CASES))
#: The program without the extension: what a scene with only plain metal-rough materials compiles.
PLAIN = Features.of(bounces=1, diffuse=True, metalrough=True, microfacet=True, separable_masking=True)


def _u(metallic, roughness, ior, specular, color, wo, base=BASE, masking="height_correlated"):
    f0, f90 = metalrough.dielectric_f0_f90(ior, specular, color)
    return dict(type="metalrough", albedo=base, alpha=roughness**2, wo=wo, front=1,
                flags=MF.flags("ggx", masking), scale=(metallic, 0.0, 0.0), mr_f0=tuple(f0), mr_f90=f90)


def spec_brdf_cos(base, metallic, roughness, ior, specular, color, wo, wi):
    """glTF appendix B with KHR_materials_ior and KHR_materials_specular, float64, written from the
    extensions' text: dielectric_brdf = fresnel_mix(f0_color = specularColor, ior, weight = specular,
    base = diffuse, layer = specular_brdf), fresnel_mix: f0 = min(((1 - ior) / (1 + ior))^2 f0_color, 1),
    fr = f0 + (1 - f0) (1 - |v.h|)^5, (1 - weight max_value(fr)) base + weight fr layer; f |cos_i|."""
    base, color = np.asarray(base, np.float64), np.asarray(color, np.float64)
    a = roughness**2
    nv, nl = wo[..., 2:3], wi[..., 2:3]
    h = wo + wi
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    nh = h[..., 2:3]
    vh = np.abs((wo * h).sum(-1, keepdims=True))
    d = a * a / (np.pi * (nh * nh * (a * a - 1.0) + 1.0) ** 2)
    v = 0.5 / (nl * np.sqrt(nv * nv * (1 - a * a) + a * a) + nv * np.sqrt(nl * nl * (1 - a * a) + a * a))
    layer, diffuse = v * d, base / np.pi
    metal = layer * (base + (1 - base) * (1 - vh) ** 5)
    f0 = np.minimum(((1 - ior) / (1 + ior)) ** 2 * color, 1.0)
    fr = f0 + (1 - f0) * (1 - vh) ** 5
    dielectric = (1 - specular * fr.max(-1, keepdims=True)) * diffuse + specular * fr * layer
    f = dielectric * (1 - metallic) + metal * metallic
    return np.where((nl > 0) & (nv > 0), f * nl, 0.0)


def _albedo_quadrature(case, mu, n=384):
    v = (np.arange(n) + 0.5) / n
    ci = 1.0 - v * v
    dci = 2.0 * v / n
    ph = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * np.pi
    C, P = np.meshgrid(ci, ph, indexing="ij")
    s = np.sqrt(1 - C * C)
    wi = np.stack([s * np.cos(P), s * np.sin(P), C], -1).reshape(-1, 3)
    wo = np.broadcast_to(np.array([math.sqrt(1 - mu * mu), 0.0, mu]), wi.shape)
    f = spec_brdf_cos(BASE, *case, wo, wi).reshape(n, 2 * n, 3)
    return (f * dci[:, None, None]).sum((0, 1)) * (2 * np.pi / (2 * n))


def _directions(seed, n=256):
    rng = np.random.default_rng(seed)
    wi = rng.normal(size=(n, 3))
    wi[:, 2] = np.abs(wi[:, 2]) + 0.05
    return wi / np.linalg.norm(wi, axis=1, keepdims=True)


def test_f0_f90_are_the_extensions():
    f0, f90 = metalrough.dielectric_f0_f90(1.5)
    assert np.allclose(f0, 0.04) and f90 == 1.0
    f0, f90 = metalrough.dielectric_f0_f90(2.0, 0.5, (30.0, 1.0, 0.0))  # clamped before the factor
    assert np.allclose(f0, [0.5, 0.5 / 9, 0.0]) and f90 == 0.5
    assert np.allclose(metalrough.dielectric_f0_f90(0.0)[0], 1.0)  # ior 0: Fresnel 1


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_glsl_is_the_twin_and_the_twin_is_the_extensions(gl, case):
    wi = _directions(5)
    for wo in ((0.0, 0.0, 1.0), (0.6, 0.0, 0.8), (0.0, 0.9396926, 0.3420201)):
        u = _u(*case, wo)
        got = floats(probe(gl, "eval", wi.astype(np.float32), **u)).astype(np.float64)
        f0, f90 = metalrough.dielectric_f0_f90(*case[2:])
        f, pdf = metalrough.eval_cos(BASE, case[0], case[1] ** 2, f0, f90, np.broadcast_to(wo, wi.shape), wi)
        np.testing.assert_allclose(got[:, :3], f, rtol=2e-3, atol=1e-6, err_msg=f"{case} {wo}")
        np.testing.assert_allclose(got[:, 3], pdf, rtol=2e-3, atol=1e-6, err_msg=f"{case} {wo}")
        want = spec_brdf_cos(BASE, *case, np.broadcast_to(wo, wi.shape), wi)
        np.testing.assert_allclose(f, want, rtol=1e-7, atol=1e-12)  # two float64 forms of D V


def test_extension_path_with_defaults_is_the_plain_material(gl):
    """The extension's code at F0 0.04, F90 1 gives the plain program's values and pdfs."""
    wi = _directions(9)
    for metallic, roughness in ((0.0, 0.3), (0.4, 0.7), (1.0, 0.5)):
        u = _u(metallic, roughness, 1.5, 1.0, (1, 1, 1), (0.6, 0.0, 0.8))
        ext = floats(probe(gl, "eval", wi.astype(np.float32), **u))
        plain = floats(probe(gl, "eval", wi.astype(np.float32), features=PLAIN, **u))
        np.testing.assert_allclose(ext, plain, rtol=1e-5, atol=1e-8)


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_sampling_matches_its_pdf(gl, case):
    wo = (0.6, 0.0, 0.8)
    u = _u(*case, wo)
    rnd = uniform_numbers(N, 2, seed=zlib.crc32(repr(case).encode()))
    out = floats(probe(gl, "sample", rnd, **u))
    wi = out[:, :3].astype(np.float64)
    valid = (probe(gl, "weight", rnd, **u)[:, 3] & 1) != 0
    ev = floats(probe(gl, "eval", sphere_grid(NT, NP, IRES).astype(np.float32), **u))
    prob = cell_probabilities(ev[:, 3], NT, NP, IRES)
    p_rest = 1.0 - prob.sum()
    assert p_rest > -2e-3, prob.sum()
    observed = np.append(sphere_histogram(wi[valid], NT, NP).ravel(), (~valid).sum())
    p, stat, dof = chi2_test(observed, np.append(prob.ravel(), max(p_rest, 0.0)) * N)
    print(f"{case}: chi2 p = {p:.3g} ({dof} dof)")
    assert p > ALPHA, f"chi2 = {stat:.1f} for {dof} dof, p = {p:.3g}"
    pick = np.nonzero(valid)[0][:4096]
    ev_s = floats(probe(gl, "eval", wi[pick].astype(np.float32), **u))
    np.testing.assert_allclose(out[pick, 3], ev_s[:, 3], rtol=2e-3)
    w = floats(probe(gl, "weight", rnd[pick], **u))[:, :3]
    np.testing.assert_allclose(w, ev_s[:, :3] / ev_s[:, 3:4], rtol=2e-3, atol=1e-6)


def test_white_furnace_energy_is_the_quadrature(gl):
    """Mean sample weight = the directional albedo by quadrature of the extensions' BRDF; with
    specularFactor 0 the dielectric is the Lambertian base alone (albedo = base colour)."""
    for case in CASES:
        for deg in (0.0, 45.0, 75.0):
            mu = math.cos(math.radians(deg))
            u = _u(*case, (math.sqrt(1 - mu * mu), 0.0, mu))
            w = floats(probe(gl, "weight", uniform_numbers(1 << 16, 2, 3), **u))[:, :3].astype(np.float64)
            e = _albedo_quadrature(case, mu)
            se = w.std(0) / math.sqrt(len(w))
            assert np.all(np.abs(w.mean(0) - e) < 4 * se + 2e-3), (case, deg, w.mean(0), e)
    e = _albedo_quadrature((0.0, 0.4, 1.5, 0.0, (1, 1, 1)), 0.8)
    np.testing.assert_allclose(e, BASE, rtol=2e-3)


def test_rendered_furnace_is_the_quadrature(gl):
    """End to end (texel 4 packed and read): inside an emitting (Le = 1) sphere, one bounce, each
    pixel is 1 + E(1) of the extensions' BRDF."""
    from .test_materials_render import furnace
    from .test_materials_render import render as render_world

    mat = ("{type: metalrough, albedo: [0.8, 0.5, 0.2], metallic: 0.2, roughness: 0.6, ior: 2.0, specular: 0.7, "
           "specular_color: [1.5, 1.0, 0.3], emission: [1, 1, 1]}")
    res, f = render_world(gl, furnace(mat, bounces=1), 64, 7)
    assert f.uses.metalrough_specular and f.defines()["MCPT_MAT_TEXELS"] == 5
    img, var = res.image.astype(np.float64), res.variance.astype(np.float64)
    se = np.sqrt(var.reshape(-1, 3).mean(0) / (img.size / 3))
    want = 1.0 + _albedo_quadrature((0.2, 0.6, 2.0, 0.7, (1.5, 1.0, 0.3)), 1.0)
    got = img.reshape(-1, 3).mean(0)
    print(f"furnace: rendered {got}, quadrature {want}, se {se}")
    assert res.dropped_samples == 0
    assert np.all(np.abs(got - want) < 4 * se + 2e-3), (got, want, se)


def test_plain_material_compiles_as_before():
    """No extension value: MCPT_METALROUGH_SPECULAR 0 and 4 texels (the program before item 5); the
    defaults written out change nothing; any other value compiles the extension's code."""
    plain = "{type: metalrough, metallic: 0.3, roughness: 0.5}"
    for text in (plain, "{type: metalrough, metallic: 0.3, roughness: 0.5, ior: 1.5, specular: 1, "
                        "specular_color: [1, 1, 1]}"):
        d = for_world(load_world(_mat(text))).defines()
        assert d["MCPT_METALROUGH_SPECULAR"] == 0 and d["MCPT_MAT_TEXELS"] == 4, text
    for extra in ("ior: 1.4", "specular: 0.5", "specular_color: [1, 0.5, 1]", "ior: 0"):
        world = load_world(_mat(plain[:-1] + ", " + extra + "}"))
        d = for_world(world).defines()
        assert d["MCPT_METALROUGH_SPECULAR"] == 1 and d["MCPT_MAT_TEXELS"] == 5, extra
        mt = world.materials
        i = mt.types.index("metalrough")
        packed = mt.pack(np.zeros(len(mt.names)), texels=5, fifth=True).reshape(len(mt.names), 5, 4)
        f0, f90 = metalrough.dielectric_f0_f90(mt.ior[i], mt.specular[i], mt.specular_color[i])
        assert np.array_equal(packed[i, 4].view(np.float32), np.float32([*f0, f90]))


def test_yaml_bad_values():
    assert "KHR_materials_ior allows ior >= 1, or 0" in _err("{type: metalrough, ior: 0.5}")
    assert "less than or equal to 1" in _err("{type: metalrough, specular: 1.5}")
    assert "greater than or equal to 0" in _err("{type: metalrough, specular_color: [1, -1, 1]}")
    assert "has no specular" in _err("{type: plastic, specular: 0.5}")
    _mat("{type: metalrough, ior: 7.5, specular_color: [3, 3, 3]}")  # no upper bounds: the spec has none


def test_gltf_maps_ior_and_specular(tmp_path, caplog):
    ext = {"KHR_materials_ior": {"ior": 1.33},
           "KHR_materials_specular": {"specularFactor": 0.25, "specularColorFactor": [1, 0.5, 2]},
           "KHR_materials_clearcoat": {"clearcoatFactor": 1}}
    with caplog.at_level(logging.WARNING, logger="mcpt"):
        m = load_scene(gltf_scene(tmp_path, {"extensions": ext})).materials["material_0"]
    assert (m.ior, m.specular, m.specular_color) == (1.33, 0.25, (1.0, 0.5, 2.0))
    assert "KHR_materials_clearcoat" in caplog.text
    assert "KHR_materials_ior" not in caplog.text and "KHR_materials_specular" not in caplog.text
    caplog.clear()
    ext = {"KHR_materials_specular": {"specularTexture": {"index": 0}, "specularColorTexture": {"index": 0}}}
    with caplog.at_level(logging.WARNING, logger="mcpt"):
        m = load_scene(gltf_scene(tmp_path, {"extensions": ext})).materials["material_0"]
    assert "KHR_materials_specular.specularTexture (its factor alone is used)" in caplog.text
    assert "specularColorTexture" in caplog.text and (m.ior, m.specular) == (1.5, 1.0)
    path = gltf_scene(tmp_path, {"extensions": {"KHR_materials_ior": {"ior": 0}}})
    doc = json.loads(path.read_text())
    doc["extensionsRequired"] = doc["extensionsUsed"] = ["KHR_materials_ior", "KHR_materials_specular"]
    path.write_text(json.dumps(doc))
    assert load_scene(path).materials["material_0"].ior == 0.0


@pytest.mark.parametrize("ext, needles", [
    ({"KHR_materials_ior": {"ior": 0.5}}, ["KHR_materials_ior.ior 0.5 is not >= 1 or 0"]),
    ({"KHR_materials_ior": {"ior": -1}}, ["KHR_materials_ior.ior -1"]),
    ({"KHR_materials_specular": {"specularFactor": 1.5}}, ["KHR_materials_specular: specularFactor 1.5",
                                                          "[0, 1]"]),
    ({"KHR_materials_specular": {"specularFactor": -0.1}}, ["specularFactor -0.1"]),
    ({"KHR_materials_specular": {"specularColorFactor": [1, -1, 1]}}, ["specularColorFactor [1, -1, 1]"]),
])
def test_gltf_bad_values_are_one_located_line(tmp_path, ext, needles):
    out = tmp_path / "o.exr"
    line = one_error(render(gltf_scene(tmp_path, {"extensions": ext}), out), out)
    assert not lacking(line, "s.gltf: materials[0]", *needles), line

"""Materials (issue #3): BSDF energy on the GLSL code, textures, smooth normals, loading and the
data diet. Rendering tests (furnaces, estimator agreement, golden images) are in
test_materials_render.py; chi-square tests of the sampling routines in test_sampling.py."""

import math

import numpy as np
import pytest

from mcpt.gpu.features import for_world
from mcpt.gpu.pack import pack
from mcpt.scene import SceneError, parse_scene
from mcpt.shading.materials import fdr_internal, fresnel_diffuse_reflectance
from mcpt.shading.normals import octahedral_decode, octahedral_encode, pack_normals
from mcpt.shading.texture import load_texture, lookup, pack_textures, srgb_to_linear
from mcpt.shapes.world import load_world

from .conftest import ROOT, SPOT, SPOT_TEXTURE
from .draw import render as draw
from .test_materials_util import floats, probe, sphere_grid, uniform_numbers

N = 1 << 17
WOS = [(0.0, 0.0, 1.0), (0.6, 0.0, 0.8), (0.0, 0.9, math.sqrt(1 - 0.81)), (0.995, 0.0, math.sqrt(1 - 0.995**2))]


def _u(**kw):
    base = dict(type="diffuse", albedo=(1, 1, 1), alpha=0.0, ior=1.5, fdr_int=0.0, wo=(0, 0, 1), front=1)
    base.update(kw)
    return base


def _weights(gl, u, n=N, seed=0):
    out = probe(gl, "weight", uniform_numbers(n, 2, seed), **u)
    w, flags = floats(out)[:, :3].astype(np.float64), out[:, 3]
    return np.where(((flags & 1) != 0)[:, None], w, 0.0), flags


# ----------------------------------------------------------------------------------------------
# white furnace per BSDF: E[f |cos| / pdf] is the fraction of light reflected


@pytest.mark.parametrize("wo", WOS)
def test_white_lambertian_and_white_mirror_reflect_exactly_everything(gl, wo):
    for u in (_u(type="diffuse", wo=wo), _u(type="conductor", alpha=0.0, wo=wo)):
        w, flags = _weights(gl, u, n=4096)
        assert (flags & 1).all()
        np.testing.assert_array_equal(w, 1.0)  # every single sample, not just the mean


@pytest.mark.parametrize("alpha", [0.05, 0.3, 1.0])
def test_rough_white_conductor_never_creates_energy(gl, alpha):
    for wo in WOS:
        w, _ = _weights(gl, _u(type="conductor", alpha=alpha, wo=wo), seed=int(alpha * 100))
        mean, se = w[:, 0].mean(), w[:, 0].std() / math.sqrt(len(w))
        assert mean <= 1.0 + 4 * se, (alpha, wo, mean)
        # Single-scattering GGX loses energy to masking and to reflections below the horizon
        # (numpy integrals: alpha 0.05: 0.911 at cos 0.1, 0.996 at cos 0.8; alpha 0.3: 0.889 /
        # 0.856; alpha 1: 0.307 at normal incidence, where half the facets reflect downwards).
        assert mean > {0.05: 0.9, 0.3: 0.8, 1.0: 0.25}[alpha], (alpha, wo, mean)
        assert (w[:, 0] <= 1.0 + 1e-6).all()  # F G2 / G1 <= 1 for every sample


@pytest.mark.parametrize("alpha", [0.3, 0.8])
def test_rough_conductor_sampled_energy_equals_integrated_brdf(gl, alpha):
    """The mean sample weight equals the BRDF integrated over the sphere (from bsdf_eval)."""
    wo = (0.6, 0.0, 0.8)
    u = _u(type="conductor", albedo=(0.9, 0.6, 0.3), alpha=alpha, wo=wo)
    w, _ = _weights(gl, u, seed=3)
    nt, ires = 64, 8
    grid = sphere_grid(nt, 2 * nt, ires)
    f = floats(probe(gl, "eval", grid.astype(np.float32), **u))[:, :3].astype(np.float64)
    integral = f.mean(axis=0) * 4 * np.pi
    se = w.std(axis=0) / math.sqrt(len(w))
    assert np.all(np.abs(w.mean(axis=0) - integral) < 4 * se + 2e-3 * integral), (w.mean(0), integral)


def _ggx_twin(wo, wi, alpha, f0):
    """Independent numpy GGX conductor: f |cos| and pdf from the textbook formulas."""
    wo, wi = np.asarray(wo, np.float64), np.asarray(wi, np.float64)

    def lam(w):
        return (-1.0 + np.sqrt(1.0 + alpha**2 * (1.0 - w[..., 2] ** 2) / w[..., 2] ** 2)) / 2.0

    h = wo + wi
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    cos_h = h[..., 2]
    d = alpha**2 / (np.pi * (cos_h**2 * (alpha**2 - 1.0) + 1.0) ** 2)
    f = np.asarray(f0) + (1.0 - np.asarray(f0)) * (1.0 - (wi * h).sum(-1, keepdims=True)) ** 5
    g2 = 1.0 / (1.0 + lam(wo) + lam(wi))
    fcos = f * (d * g2 / (4.0 * wo[..., 2]))[..., None]
    pdf = d / (4.0 * wo[..., 2] * (1.0 + lam(wo)))
    return fcos, pdf


@pytest.mark.parametrize("alpha", [0.1, 0.5])
def test_rough_conductor_eval_matches_an_independent_twin(gl, alpha):
    rng = np.random.default_rng(11)
    wi = rng.normal(size=(2000, 3))
    wi[:, 2] = np.abs(wi[:, 2]) + 0.05
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    for wo in WOS[:3]:
        u = _u(type="conductor", albedo=(0.9, 0.5, 0.2), alpha=alpha, wo=wo)
        ev = floats(probe(gl, "eval", wi.astype(np.float32), **u)).astype(np.float64)
        fcos, pdf = _ggx_twin(np.broadcast_to(wo, wi.shape), wi, alpha, (0.9, 0.5, 0.2))
        np.testing.assert_allclose(ev[:, :3], fcos, rtol=2e-3, atol=1e-6)
        np.testing.assert_allclose(ev[:, 3], pdf, rtol=2e-3, atol=1e-6)


@pytest.mark.parametrize("wo", WOS)
def test_white_plastic_reflects_everything(gl, wo):
    u = _u(type="plastic", ior=1.5, fdr_int=fdr_internal(1.5), wo=wo)
    w, flags = _weights(gl, u, seed=4)
    mean, se = w[:, 0].mean(), w[:, 0].std() / math.sqrt(len(w))
    assert abs(mean - 1.0) < 4 * se + 1e-4, (wo, mean, se)


def test_white_plastic_diffuse_albedo_matches_the_internal_scattering_series():
    """1 - Fdr_int = (1 - Fdr_ext) / eta^2: with it, the series A (1 - Fdr_int) / (1 - A Fdr_int)
    is 1 for A = 1 whatever the index; Fdr_ext(1.5) agrees with the literature value 0.0918."""
    assert abs(fresnel_diffuse_reflectance(1.5) - 0.0918) < 5e-4
    assert abs(fdr_internal(1.5) - 0.5963) < 5e-4  # d'Eon & Irving's internal Fdr(1.5) ~ 0.596
    assert fdr_internal(1.0) == 0.0


@pytest.mark.parametrize("ior,front", [(1.5, 1), (1.5, 0), (2.4, 1)])
def test_glass_splits_light_without_loss(gl, ior, front):
    """Reflected + refracted = incident: each sample's weight times the eta^2 it crossed is 1."""
    for wo in WOS:
        u = _u(type="dielectric", ior=ior, front=front, wo=wo)
        rnd = uniform_numbers(4096, 2, 5)
        w = floats(probe(gl, "weight", rnd, **u))[:, 0].astype(np.float64)
        eta2 = floats(probe(gl, "eta2", rnd, **u))[:, 0].astype(np.float64)
        np.testing.assert_allclose(w * eta2, 1.0, rtol=1e-6)


def test_materials_reflect_nothing_below_the_surface(gl):
    below = np.array([[0.3, 0.1, -0.9], [0.0, 0.0, -1.0], [0.9, 0.0, -0.1]], np.float32)
    for u in (_u(type="diffuse"), _u(type="conductor", alpha=0.4), _u(type="plastic", fdr_int=0.6)):
        ev = floats(probe(gl, "eval", below, **u))
        assert (ev == 0).all(), u["type"]


# ----------------------------------------------------------------------------------------------
# textures


def _checker_png(tmp_path, w=7, h=5):
    import cv2

    rng = np.random.default_rng(8)
    rgb = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
    rgb[0, 0] = (0, 10, 255)  # includes values on both branches of the sRGB curve
    path = tmp_path / "tex.png"
    cv2.imwrite(str(path), rgb[:, :, ::-1])
    return path, rgb


def test_texture_loads_as_srgb_with_v_up(tmp_path):
    path, rgb = _checker_png(tmp_path)
    t = load_texture(path)
    assert (t.width, t.height) == (7, 5)
    assert np.array_equal(t.srgb, rgb[::-1])  # row 0 = bottom of the image
    assert abs(srgb_to_linear(255) - 1.0) < 1e-12 and srgb_to_linear(0) == 0.0
    assert abs(srgb_to_linear(10) - 10 / 255 / 12.92) < 1e-12  # linear segment
    assert abs(srgb_to_linear(128) - 0.2158605) < 1e-6


@pytest.mark.parametrize("wrap", ["repeat", "clamp", "mirror"])
@pytest.mark.parametrize("filt", ["bilinear", "nearest"])
def test_glsl_texture_lookup_matches_the_reference(gl, tmp_path, wrap, filt):
    path, _ = _checker_png(tmp_path)
    small = load_texture(path, wrap, filt)
    spot = load_texture(SPOT_TEXTURE, wrap, filt)
    buf = pack_textures([small, spot])
    rng = np.random.default_rng(9)
    for tid, t in enumerate((small, spot)):
        uv = rng.uniform(-2.5, 3.5, (20000, 2))
        items = np.zeros((len(uv), 3), np.uint32)
        items[:, :2] = uv.astype(np.float32).view(np.uint32)
        items[:, 2] = tid
        got = floats(probe(gl, "texture", items, tbos={"textures": buf}))[:, :3]
        want = lookup(t, uv.astype(np.float32).astype(np.float64))
        # float32 texel coordinates (the reference folds them in float64): bilinear weights differ
        # by ~1e-4 texel on the 1024-texel Spot, and nearest lookups within rounding of a texel
        # border may land on either side. A wrong texel or curve is off by ~0.1.
        ok = np.abs(got - want).max(axis=1) < 5e-4
        assert ok.mean() > (0.999 if filt == "nearest" else 1.0 - 1e-9), (tid, ok.mean())


def test_texture_errors_name_the_file(tmp_path):
    bad = tmp_path / "broken.png"
    bad.write_bytes(b"not a png")
    with pytest.raises(ValueError, match="broken.png"):
        load_texture(bad)


# ----------------------------------------------------------------------------------------------
# smooth normals


def test_shading_normals_decode_and_interpolate_on_the_gpu(gl):
    rng = np.random.default_rng(10)
    n = rng.normal(size=(500, 3, 3))
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    n[:, 1] = n[:, 0] + 0.3 * n[:, 1]  # keep corners roughly aligned, like a real mesh
    n[:, 2] = n[:, 0] + 0.3 * n[:, 2]
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    bary = rng.dirichlet([1, 1, 1], 500)[:, 1:]
    items = np.zeros((500, 3), np.uint32)
    items[:, 0] = np.arange(500)
    items[:, 1:] = bary.astype(np.float32).view(np.uint32)
    got = floats(probe(gl, "normal", items, tbos={"normals": pack_normals(n.astype(np.float32))}))[:, :3]
    dec = octahedral_decode(octahedral_encode(n))
    want = (1 - bary.sum(1))[:, None] * dec[:, 0] + bary[:, :1] * dec[:, 1] + bary[:, 1:] * dec[:, 2]
    want /= np.linalg.norm(want, axis=1, keepdims=True)
    np.testing.assert_allclose(got, want, atol=1e-4)  # float32, fast-math normalize
    assert np.degrees(np.arccos(np.clip((dec * n).sum(-1), -1, 1))).max() < 0.004


# ----------------------------------------------------------------------------------------------
# scene files, loading, data diet

BOX = ROOT / "scenes" / "cornell"
SPHERE = ROOT / "scenes" / "models" / "icosphere.obj"


def _scene(materials: str, meshes: str, tmp_path=None):
    text = f"""
camera: {{position: [0, 0, 3.9], look_at: [0, 0, 0], vfov_deg: 39.3, resolution: [16, 16]}}
render: {{spp: 4, bounces: 4}}
materials:
{materials}
meshes:
{meshes}
"""
    return parse_scene(text, (tmp_path or ROOT / "scenes") / "inline.yaml")


def test_material_parameters_are_validated_per_type():
    def err(mat):
        with pytest.raises(SceneError) as e:
            _scene(f"  m: {mat}", f"  - {{file: {SPHERE}, material: m}}")
        return str(e.value)

    assert "diffuse material has no roughness" in err("{type: diffuse, roughness: 0.2}")
    assert "dielectric material has no albedo" in err("{type: dielectric, albedo: [1, 1, 1]}")
    assert "conductor material has no ior" in err("{type: conductor, ior: 1.5}")
    assert "not both" in err("{albedo: [1, 1, 1], albedo_texture: " + str(SPOT_TEXTURE) + "}")
    assert "less than or equal to 1" in err("{type: conductor, roughness: 1.5}")
    assert "texture file not found" in err("{albedo_texture: nope.png}")
    assert "greater than 0" in err("{type: dielectric, absorption: {color: [0.5, 0, 1], distance: 1}}")


def test_diffuse_scene_uploads_no_normals_uvs_or_material_parameters():
    from mcpt.scene import load_scene

    world = load_world(load_scene(ROOT / "scenes" / "cornell-box.yaml"))
    f = for_world(world)
    u = f.uses
    assert not (u.conductor or u.dielectric or u.plastic or u.textures or u.smooth_normals)
    assert world.normals is None and world.uvs is None and not world.textures
    bufs = pack(world, f).buffers
    assert set(bufs) == {"tris", "nodes", "materials", "lights"} - ({"nodes"} if not f.bvh else set())
    assert bufs["materials"].shape[0] == 2 * len(world.materials.names)  # 2 texels per material
    d = f.defines()
    for key in ("MCPT_MAT_CONDUCTOR", "MCPT_MAT_DIELECTRIC", "MCPT_MAT_PLASTIC", "MCPT_TEXTURES",
                "MCPT_SMOOTH_NORMALS", "MCPT_DELTA", "MCPT_MICROFACET"):
        assert d[key] == 0, key


def test_features_follow_the_materials_a_scene_uses(tmp_path):
    spot = SPOT
    tex = SPOT_TEXTURE
    s = _scene(f"""  cow: {{albedo_texture: {tex}, smooth_normals: true}}
  metal: {{type: conductor, roughness: 0.2}}
  mirror: {{type: conductor}}
  glass: {{type: dielectric, absorption: {{color: [0.5, 0.8, 0.9], distance: 0.5}}}}
  unused: {{type: plastic}}
  lamp: {{emission: [5, 5, 5]}}""",
               f"""  - {{file: {spot}, material: cow}}
  - {{file: {SPHERE}, material: metal, transform: {{translate: [2, 0, 0]}}}}
  - {{file: {SPHERE}, material: mirror, transform: {{translate: [-2, 0, 0]}}}}
  - {{file: {SPHERE}, material: glass, transform: {{translate: [0, 2, 0]}}}}
  - {{file: {BOX}/light.obj, material: lamp}}""", tmp_path)
    world = load_world(s)
    f = for_world(world)
    u = f.uses
    assert u.diffuse and u.conductor and u.microfacet and u.dielectric and u.absorption
    assert not u.plastic  # defined but used by no mesh
    assert u.textures and u.smooth_normals and u.material_texels == 4
    assert len(world.textures) == 1 and world.uvs.shape == (world.n_triangles, 3, 2)
    bufs = pack(world, f).buffers
    assert {"normals", "uvs", "textures"} <= set(bufs)
    mt = world.materials
    glass = mt.names.index("glass")
    np.testing.assert_allclose(mt.sigma_a[glass], -np.log([0.5, 0.8, 0.9]) / 0.5)
    # Normals were generated only for the smooth mesh: the rest of the table is zero.
    cow = mt.names.index("cow")
    has_n = np.abs(world.normals).sum(axis=(1, 2)) > 0
    assert np.array_equal(has_n, world.tri_material == cow)
    # Vertex normals of the smooth mesh point to the same side as the face normals.
    tri = world.tris[world.tri_material == cow].astype(np.float64)
    fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert ((world.normals[world.tri_material == cow].mean(axis=1) * fn).sum(1) > 0).mean() > 0.99


# ----------------------------------------------------------------------------------------------
# leaving out what a scene does not use (issue #4)

MATERIAL_CODE = ("dielectric_sample", "conductor_sample", "plastic_sample", "fresnel_dielectric",
                 "ggx_D", "texture_rgb", "tri_uv", "shading_normal_raw", "u_normals", "u_textures")


def test_diffuse_scene_shader_source_has_no_other_material_code():
    from mcpt.gpu.features import Features
    from mcpt.gpu.shader import Source

    uber = Source("pathtrace.frag", Features.of(bounces=8).everything().preamble()).text
    assert all(word in uber for word in MATERIAL_CODE)
    text = Source("pathtrace.frag", Features.of(bounces=8).preamble()).text
    assert [w for w in MATERIAL_CODE if w in text] == []


def test_textured_smooth_scene_renders_through_the_api(gl):
    from mcpt.api import prepare

    p = prepare(ROOT / "scenes" / "spot.yaml", resolution=(8, 8), bounces=1)
    try:
        assert {"normals", "uvs", "textures"} <= set(p.renderer.tbos)
        assert draw(p.renderer, 1, 0).dropped_samples == 0
    finally:
        p.renderer.release()

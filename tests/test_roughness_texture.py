"""Roughness textures (issue #22, mcpt/shading/roughness_texture.py): a rough conductor's or rough
dielectric's alpha read per hit from a texture, times its roughness.

* A constant texture renders as the untextured material: exactly where the product is exact (a
  white texel times the roughness), within float rounding where it is not.
* A two-valued texture on a plane that the camera sees half and half renders, pixel for pixel, as
  the untextured material of each half's alpha there (a plane never lights itself, so the halves do
  not mix): a z-test (mcpt.bench.stats) of the composite of two untextured renders. Light sampling
  and BSDF sampling both run at each hit (MIS), so an alpha seen by one and not the other would bias
  the image.
* Sampling at a textured alpha is sampling at that alpha: the per-alpha chi-square tests of
  tests/test_sampling.py (BSDF_CASES: GGX and Beckmann conductors and rough glass at several
  alphas) cover it; the texture only chooses which alpha, once per hit.
* Bad input: one located line.
"""

import numpy as np
import pytest

from mcpt.bench.stats import z_test
from mcpt.scene import SceneError, load_scene, parse_scene
from mcpt.shading.materials import MIN_ALPHA
from mcpt.shading.roughness_texture import SHIFT
from mcpt.shapes.world import load_world

from .conftest import ROOT
from .test_materials_render import render

#: A rough plane [-1, 1]^2 (UVs over it, u = 0.5 at x = 0) seen from above; a square lamp behind the
#: camera (the highlight: light sampling and BSDF sampling, MIS), for glass one more below the plane
#: (light through it: BSDF sampling alone, the plane hides it from light sampling).
SCENE = """
camera: {{position: [0, 0, 3], look_at: [0, 0, 0], up: [0, 1, 0], vfov_deg: 30, resolution: [{res}, {res}]}}
render: {{bounces: 2}}
materials:
  m: {material}
  lamp: {{albedo: [0, 0, 0], emission: [2, 2, 2]}}
meshes:
  - {{shape: rectangle, material: m}}
  - {{shape: rectangle, material: lamp, transform: {ABOVE}}}
{lamp}"""
ABOVE = "{scale: 0.8, rotate_deg: [180, 0, 0], translate: [0.3, 0.2, 3.5]}"  # faces -z, behind the camera
BELOW = "  - {shape: rectangle, material: lamp, transform: {scale: 1.5, translate: [0.2, 0.1, -1]}}\n"


def _scene(tmp_path, material: str, lamp: str = "", res: int = 16):
    return parse_scene(SCENE.format(material=material, lamp=lamp, res=res, ABOVE=ABOVE), tmp_path / "s.yaml")


def _png(tmp_path, name: str, grey) -> str:
    """A grey PNG of rows ``grey`` (top row first), e.g. [[255, 51]]: left half 255, right half 51."""
    import cv2

    path = tmp_path / name
    assert cv2.imwrite(str(path), np.asarray(grey, np.uint8))
    return str(path)


def _conductor(rough: str) -> str:
    return "{type: conductor, albedo: [0.9, 0.7, 0.5], distribution: ggx, " + rough + "}"


def _glass(rough: str) -> str:
    return "{type: roughdielectric, ior: 1.5, " + rough + "}"


CASES = {"conductor": (_conductor, ""), "roughdielectric": (_glass, BELOW)}


@pytest.mark.parametrize("kind", list(CASES))
def test_white_texture_is_the_untextured_material(gl, tmp_path, kind):
    """A white texel is 1 exactly (nearest: no interpolation), so alpha = roughness x 1 is the table's
    alpha bit for bit, and the textured render is the untextured one, pixel for pixel."""
    make, lamp = CASES[kind]
    white = _png(tmp_path, "white.png", np.full((4, 4), 255))
    a, fa = render(gl, _scene(tmp_path, make(f"roughness: 0.3, roughness_texture: {{file: {white}, "
                                             "filter: nearest}"), lamp), 4, 11)
    b, fb = render(gl, _scene(tmp_path, make("roughness: 0.3"), lamp), 4, 11)
    assert fa.defines()["MCPT_ROUGHNESS_TEXTURES"] == 1 and fb.defines()["MCPT_ROUGHNESS_TEXTURES"] == 0
    assert a.image.mean() > 0.02 and a.dropped_samples == b.dropped_samples == 0
    np.testing.assert_array_equal(a.image, b.image)


@pytest.mark.parametrize("kind", list(CASES))
def test_black_texture_is_the_least_alpha(gl, tmp_path, kind):
    """A black texel gives alpha 0, floored at the least alpha the material takes (MIN_ALPHA): the
    render is the untextured material at roughness MIN_ALPHA, pixel for pixel."""
    make, lamp = CASES[kind]
    black = _png(tmp_path, "black.png", np.zeros((4, 4)))
    a, _ = render(gl, _scene(tmp_path, make(f"roughness: 0.5, roughness_texture: {black}"), lamp), 4, 5)
    b, _ = render(gl, _scene(tmp_path, make(f"roughness: {MIN_ALPHA!r}"), lamp), 4, 5)
    print(kind, a.image.mean())
    assert a.image.mean() > 1e-3 and a.dropped_samples == b.dropped_samples == 0
    np.testing.assert_array_equal(a.image, b.image)


@pytest.mark.parametrize("encoding", ["linear", "srgb"])
def test_grey_texture_is_roughness_times_its_value(gl, tmp_path, encoding):
    """A constant grey 128 (bilinear, the default) scales roughness by 128/255 read linearly, or by
    its sRGB decoding (Mitsuba's bitmap without raw): the render is the untextured material at that
    alpha within float rounding (the product differs from the table's float32 by an ulp)."""
    from mcpt.shading.texture import srgb_to_linear

    grey = _png(tmp_path, "grey.png", np.full((4, 4), 128))
    v = 128 / 255 if encoding == "linear" else float(srgb_to_linear(128))
    a, _ = render(gl, _scene(tmp_path, _conductor(f"roughness: 0.6, roughness_texture: {{file: {grey}, "
                                                  f"encoding: {encoding}}}")), 8, 3)
    b, _ = render(gl, _scene(tmp_path, _conductor(f"roughness: {0.6 * v!r}")), 8, 3)
    assert a.image.mean() > 0.02
    np.testing.assert_allclose(a.image.mean(), b.image.mean(), rtol=1e-4)
    np.testing.assert_allclose(a.image, b.image, rtol=1e-3, atol=1e-4)


@pytest.mark.parametrize("kind", list(CASES))
def test_two_valued_texture_is_the_mix_of_the_untextured_renders(gl, tmp_path, kind):
    """Left half of the plane alpha 0.5 (texel 255 x roughness 0.5), right half 0.1 (texel 51): each
    image half is the untextured render at its alpha (z-test of the composite, 24 x 24 pixels)."""
    make, lamp = CASES[kind]
    tex = _png(tmp_path, "halves.png", [[255, 51]])
    res, spp = 24, 256
    a, _ = render(gl, _scene(tmp_path, make(f"roughness: 0.5, roughness_texture: {{file: {tex}, filter: nearest}}"),
                             lamp, res), spp, 21)
    lo, _ = render(gl, _scene(tmp_path, make("roughness: 0.5"), lamp, res), spp, 22)
    hi, _ = render(gl, _scene(tmp_path, make("roughness: 0.1"), lamp, res), spp, 23)
    left = (np.arange(res) < res // 2)[None, :, None]  # image columns left of x = 0: u < 0.5
    ref = np.where(left, lo.image, hi.image).astype(np.float64)
    var_ref = np.where(left, lo.variance, hi.variance).astype(np.float64)
    t = z_test(a.image, ref, a.variance, var_ref, var_floor=1e-4 / spp)
    print(kind, t.summary())
    assert t.passed, t.summary()
    # The halves differ by far more than the noise: the test would see a texture read wrongly.
    assert abs(lo.image[:, : res // 2].mean() - hi.image[:, : res // 2].mean()) > 20 * np.sqrt(
        a.variance[:, : res // 2].mean() / (res * res / 2))


def test_compiled_only_when_used_and_packed_in_the_flags(tmp_path):
    tex = _png(tmp_path, "r.png", [[200, 100]])
    world = load_world(_scene(tmp_path, _conductor(f"roughness_texture: {tex}")))
    mt = world.materials
    i = mt.names.index("m")
    assert mt.alpha[i] == 1.0 and mt.roughness_texture[i] >= 0  # no roughness: the texture is alpha
    from mcpt.gpu.features import for_world

    d = for_world(world).defines()
    assert d["MCPT_ROUGHNESS_TEXTURES"] == d["MCPT_TEXTURES"] == d["MCPT_MICROFACET"] == 1
    packed = mt.pack(np.zeros(len(mt.names)), texels=4).reshape(len(mt.names), 4, 4)
    assert packed[i, 2, 3] >> SHIFT == mt.roughness_texture[i] + 1
    assert packed[mt.names.index("lamp"), 2, 3] >> SHIFT == 0
    plain = load_world(_scene(tmp_path, _conductor("roughness: 0.2")))
    assert for_world(plain).defines()["MCPT_ROUGHNESS_TEXTURES"] == 0
    # The shader's floor is the materials' (glsl/roughness_texture.glsl).
    src = (ROOT / "glsl" / "roughness_texture.glsl").read_text()
    assert f"clamp(m.alpha * r, {MIN_ALPHA:g}, 1.0)" in src


def _err(tmp_path, material: str) -> str:
    with pytest.raises(SceneError) as e:
        load_world(_scene(tmp_path, material))
    msg = str(e.value)
    assert "\n" not in msg.strip()
    return msg


def test_bad_input_is_one_located_line(tmp_path):
    tex = _png(tmp_path, "r.png", [[200, 100]])
    missing = tmp_path / "nope.png"
    msg = _err(tmp_path, _conductor(f"roughness: 0.2, roughness_texture: {missing}"))
    assert "s.yaml" in msg and "roughness_texture" in msg and "nope.png" in msg
    for t in ("diffuse", "dielectric", "plastic", "thindielectric", "metalrough"):
        msg = _err(tmp_path, f"{{type: {t}, roughness_texture: {tex}}}")
        assert "s.yaml" in msg and f"a {t} material has no roughness_texture" in msg, msg
        assert "conductor, roughdielectric" in msg
    msg = _err(tmp_path, f"{{type: roughplastic, roughness: 0.2, roughness_texture: {tex}}}")
    assert "roughplastic takes no roughness_texture" in msg and "one alpha" in msg
    msg = _err(tmp_path, _conductor(f"roughness: 0, roughness_texture: {tex}"))
    assert "roughness 0 with a roughness_texture" in msg
    assert "encoding" in _err(tmp_path, _conductor(f"roughness_texture: {{file: {tex}, encoding: gamma}}"))


def _xml(tmp_path, bsdf: str):
    from .test_mitsuba import write_xml

    return write_xml(tmp_path, f'<shape type="rectangle">{bsdf}</shape>')


def test_mitsuba_alpha_bitmap_is_an_srgb_roughness_texture(tmp_path):
    """Mitsuba 3's bitmap without raw sRGB-decodes every PNG, grey ones and alpha included (its
    Bitmap marks PNGs sRGB; Mitsuba 3.9.1 evaluates a grey 128 PNG to 0.2159 = srgb_to_linear(128));
    raw=true reads it linearly. Either becomes roughness_texture with roughness absent (1)."""
    from mcpt.scene.mitsuba import scene_data

    grey = _png(tmp_path, "a.png", np.full((2, 2), 128))
    for raw, encoding in (("", "srgb"), ('<boolean name="raw" value="true"/>', "linear")):
        for kind in ("roughconductor", "roughdielectric"):
            path = _xml(tmp_path, f'<bsdf type="{kind}"><string name="distribution" value="ggx"/><texture '
                                  f'type="bitmap" name="alpha"><string name="filename" value="{grey}"/>{raw}'
                                  '</texture></bsdf>')
            mat = next(iter(scene_data(path)[0]["materials"].values()))
            assert mat["roughness_texture"]["encoding"] == encoding and "roughness" not in mat, mat
            assert mat["masking"] == "separable" and mat["distribution"] == "ggx"
    world = load_world(load_scene(path))
    i = world.materials.types.index("roughdielectric")
    assert world.materials.alpha[i] == 1.0 and world.materials.roughness_texture[i] >= 0


@pytest.mark.parametrize("bsdf,pattern", [
    ('<bsdf type="roughplastic"><texture type="bitmap" name="alpha"><string name="filename" value="{g}"/>'
     '</texture></bsdf>', "roughplastic's alpha is a number"),
    ('<bsdf type="roughconductor"><texture type="bitmap" name="alpha_u"><string name="filename" value="{g}"/>'
     '</texture><float name="alpha_v" value="0.1"/></bsdf>', "anisotropic roughness"),
    ('<bsdf type="roughconductor"><texture type="checkerboard" name="alpha"/></bsdf>', "must be a bitmap"),
    ('<bsdf type="roughconductor"><texture type="bitmap" name="alpha"><string name="filename" value="{c}"/>'
     '</texture></bsdf>', "colour image as alpha"),
])
def test_mitsuba_alpha_texture_refusals(tmp_path, bsdf, pattern):
    grey = _png(tmp_path, "a.png", np.full((2, 2), 128))
    colour = _png(tmp_path, "c.png", np.dstack([np.full((2, 2), v) for v in (10, 20, 30)]))
    path = _xml(tmp_path, bsdf.format(g=grey, c=colour))
    with pytest.raises(SceneError) as err:
        load_world(load_scene(path))
    msg = str(err.value)
    assert "\n" not in msg and "s.xml:" in msg and pattern in msg, msg

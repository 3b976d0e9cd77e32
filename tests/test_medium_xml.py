"""Mitsuba 3 media in XML scenes (issue #25): the sensor's homogeneous medium and its phase function
become mcpt's scene-wide ``medium:``; what mcpt cannot render the same is one located line."""

from __future__ import annotations

import numpy as np
import pytest

from mcpt.scene import SceneError, load_scene

from .conftest import ROOT

FOG_SPOT = ROOT / "bench" / "scenes-xml" / "media-fog-spot.xml"


def fog_xml(tmp_path, medium: str, integrator: str = "volpath", sensor_ref: str = '<ref id="fog"/>'):
    path = tmp_path / "fog.xml"
    path.write_text(f"""<scene version="3.0.0">
<integrator type="{integrator}"/>
{medium}
<sensor type="perspective">
    {sensor_ref}
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
</sensor>
<shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
</scene>
""")
    return path


def test_shipped_fog_scene_maps_albedo_sigma_t_and_hg():
    sc = load_scene(FOG_SPOT)
    m = sc.medium
    assert m.albedo == (0.9, 0.85, 0.8) and m.density == (0.4, 0.4, 0.4) and m.g == 0.5
    sigma_t, sigma_s = m.coefficients
    assert np.allclose(sigma_s, [0.36, 0.34, 0.32]) and np.allclose(sigma_t, 0.4)


def test_mitsuba_defaults_and_a_nested_medium(tmp_path):
    """Mitsuba's defaults: albedo 0.75, sigma_t 1, hg's g 0.8, isotropic without a phase; scale."""
    m = load_scene(fog_xml(tmp_path, '<medium type="homogeneous" id="fog"><phase type="hg"/></medium>')).medium
    assert m.albedo == (0.75,) * 3 and m.density == (1.0,) * 3 and m.g == 0.8
    nested = '<medium type="homogeneous"><float name="scale" value="3"/><rgb name="sigma_t" value="1, 2, 3"/></medium>'
    m = load_scene(fog_xml(tmp_path, "", sensor_ref=nested)).medium
    assert m.g == 0.0 and np.allclose(m.coefficients[0], [3, 6, 9])


HOMOGENEOUS = '<medium type="homogeneous" id="fog">{}</medium>'
BAD = [
    ('<medium type="heterogeneous" id="fog"/>', "volpath",
     ':3: <medium type="heterogeneous" id="fog">: not supported by mcpt'),
    (HOMOGENEOUS.format('<phase type="rayleigh"/>'), "volpath", ':3: <phase type="rayleigh">: not supported'),
    (HOMOGENEOUS.format('<float name="sigma_a" value="1"/>'), "volpath",
     ":3: <float name=\"sigma_a\">: 'sigma_a' is not a parameter"),
    (HOMOGENEOUS.format(""), "path", ':3: <medium type="homogeneous" id="fog">: the path integrator ignores media'),
    (HOMOGENEOUS.format('<phase type="hg"><float name="g" value="1"/></phase>'), "volpath",
     ":3: medium.g: Input should be less than 1"),
    (HOMOGENEOUS.format('<float name="sigma_t" value="-2"/>'), "volpath",
     ":3: medium.density.0: Input should be greater than or equal to 0"),
]


@pytest.mark.parametrize("medium,integrator,message", BAD)
def test_bad_media_are_one_located_line(tmp_path, medium, integrator, message):
    with pytest.raises(SceneError) as exc:
        load_scene(fog_xml(tmp_path, medium, integrator))
    text = str(exc.value)
    assert "\n" not in text and message in text, text


SMOKE = ROOT / "bench" / "scenes-xml" / "media-smoke-sphere.xml"


def test_interior_media_map_to_dielectrics():
    """A null BSDF around an interior medium is an index-matched dielectric (ior 1) holding it; a
    dielectric keeps its ior and gets the interior."""
    sc = load_scene(SMOKE)
    by_ior = {round(m.ior, 3): m for m in sc.materials.values() if m.type == "dielectric"}
    assert set(by_ior) == {1.0, 1.5}  # 1.5 / Mitsuba's air (1.000277)
    smoke, tint = by_ior[1.0].interior, by_ior[1.5].interior
    assert smoke.albedo == (0.95, 0.9, 0.8) and smoke.density == (4.0,) * 3 and smoke.g == 0.3
    assert tint.albedo == (0.6, 0.8, 0.9) and tint.g == 0.0


def shape_xml(tmp_path, shape_body: str, sensor_medium: bool = False):
    path = tmp_path / "shape.xml"
    path.write_text(f"""<scene version="3.0.0">
<integrator type="volpath"/>
<medium type="homogeneous" id="fog"/>
<medium type="homogeneous" id="smoke"/>
<sensor type="perspective">{'<ref id="fog"/>' if sensor_medium else ''}
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
</sensor>
<shape type="sphere">{shape_body}</shape>
<constant/>
</scene>
""".replace("<constant/>", '<emitter type="constant"/>'))
    return path


@pytest.mark.parametrize("body,fog,message", [
    ('<bsdf type="diffuse"/><ref name="interior" id="smoke"/>', False,
     ':8: <shape type="sphere">: an interior medium needs a dielectric or null BSDF'),
    ('<bsdf type="null"/>', False, ':8: <bsdf type="null">: a null BSDF is supported by mcpt only around'),
    ('<bsdf type="dielectric"/><ref name="interior" id="smoke"/>', True,
     ':8: <shape type="sphere">: a transmitting shape in a scene with a sensor medium needs'),
    ('<bsdf type="dielectric"/><ref name="exterior" id="smoke"/>', True,
     ":8: <shape type=\"sphere\">: mcpt's outside of every shape is the sensor's medium"),
])
def test_bad_shape_media_are_one_located_line(tmp_path, body, fog, message):
    with pytest.raises(SceneError) as exc:
        load_scene(shape_xml(tmp_path, body, fog))
    assert "\n" not in str(exc.value) and message in str(exc.value), str(exc.value)


def test_glass_in_fog_with_the_fog_outside_is_accepted(tmp_path):
    sc = load_scene(shape_xml(tmp_path, '<bsdf type="dielectric"/><ref name="exterior" id="fog"/>', True))
    assert sc.medium is not None and all(m.interior is None for m in sc.materials.values())

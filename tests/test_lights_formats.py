"""Mitsuba 3 emitters -> mcpt lights (issue #20, mcpt/scene/mitsuba/emitters.py)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from mcpt.scene import SceneError, load_scene

from .test_mitsuba import write_xml

SPHERE = '<shape type="sphere"/>'


def test_point_spot_directional_constant_are_mapped(tmp_path):
    path = write_xml(tmp_path, SPHERE + """
<emitter type="point"><point name="position" x="1" y="2" z="3"/><rgb name="intensity" value="1, 2, 3"/></emitter>
<emitter type="point"><transform name="to_world"><translate x="4"/></transform></emitter>
<emitter type="spot">
  <transform name="to_world"><lookat origin="0, 5, 0" target="0, 0, 0" up="0, 0, 1"/></transform>
  <float name="cutoff_angle" value="30"/>
</emitter>
<emitter type="directional">
  <vector name="direction" x="0" y="-2" z="0"/><rgb name="irradiance" value="5, 5, 5"/>
</emitter>
<emitter type="directional"><transform name="to_world"><rotate x="1" angle="90"/></transform></emitter>
<emitter type="constant"><rgb name="radiance" value="0.5, 0.6, 0.7"/></emitter>
""")
    s = load_scene(path)
    p0, p1, spot, d0, d1 = s.lights
    assert (p0.position, p0.intensity) == ((1, 2, 3), (1, 2, 3))
    assert p1.position == (4, 0, 0) and p1.intensity == (1, 1, 1)  # Mitsuba's default intensity 1
    assert spot.position == (0, 5, 0) and spot.cutoff == 30 and spot.beam == pytest.approx(22.5)
    np.testing.assert_allclose(spot.axis, [0, -1, 0], atol=1e-12)  # local +z, look_at's forward
    np.testing.assert_allclose(d0.axis, [0, -1, 0])
    assert d0.irradiance == (5, 5, 5)
    np.testing.assert_allclose(d1.axis, [0, -1, 0], atol=1e-12)  # +z turned 90 degrees about x
    assert s.environment.radiance == (0.5, 0.6, 0.7)
    assert math.isclose(d1.irradiance[0], 1.0)


@pytest.mark.parametrize(("body", "pattern"), [
    ('<emitter type="projector"/>', r'<emitter type="projector">: not supported by mcpt'),
    ('<emitter type="point"><float name="scale" value="2"/></emitter>', r"'scale' is not a parameter"),
    ('<emitter type="spot"><float name="cutoff_angle" value="10"/><float name="beam_width" value="20"/>'
     '</emitter>', r"beam_deg 20 exceeds cutoff_deg 10"),
    ('<emitter type="point"><rgb name="intensity" value="0, 0, 0"/></emitter>', r"intensity is zero"),
])
def test_bad_emitters_are_one_located_line(tmp_path, body, pattern):
    path = write_xml(tmp_path, SPHERE + body)
    with pytest.raises(SceneError) as err:
        load_scene(path)
    msg = str(err.value)
    assert "\n" not in msg and str(path) in msg and re.search(pattern, msg), msg


# --- glTF KHR_lights_punctual ------------------------------------------------------------------

def test_gltf_punctual_lights_are_placed_by_their_node_in_radiometric_units(tmp_path):
    from .test_gltf import small_scene

    b = small_scene()
    b.doc["extensionsRequired"] = ["KHR_lights_punctual"]
    b.doc["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1, 0.5, 0.25], "intensity": 683},
        {"type": "spot", "intensity": 1366, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}},
        {"type": "directional", "intensity": 6830}]}}
    b.node(translation=[1, 2, 3], extensions={"KHR_lights_punctual": {"light": 0}})
    # rotated +90 degrees about x: local -Z becomes world +Y
    q = [math.sin(math.pi / 4), 0, 0, math.cos(math.pi / 4)]
    b.node(translation=[0, -1, 0], rotation=q, extensions={"KHR_lights_punctual": {"light": 1}})
    b.node(extensions={"KHR_lights_punctual": {"light": 2}})
    s = load_scene(b.write_gltf(tmp_path / "l.gltf"))
    point, spot, sun = s.lights
    assert point.position == pytest.approx((1, 2, 3)) and point.intensity == pytest.approx((1, 0.5, 0.25))
    assert spot.intensity == pytest.approx((2, 2, 2)) and spot.position == pytest.approx((0, -1, 0))
    np.testing.assert_allclose(spot.axis, [0, 1, 0], atol=1e-12)
    assert spot.cutoff == pytest.approx(math.degrees(0.5)) and spot.beam == pytest.approx(math.degrees(0.2))
    np.testing.assert_allclose(sun.axis, [0, 0, -1])
    assert sun.irradiance == pytest.approx((10, 10, 10))


@pytest.mark.parametrize(("light", "pattern"), [
    ({"type": "area"}, r"lights\[0\]: type 'area': expected point, spot or directional"),
    ({"type": "point", "intensity": -1}, r"intensity must be a number in \[0, inf\]"),
    ({"type": "spot", "spot": {"outerConeAngle": 0.2, "innerConeAngle": 0.3}}, r"innerConeAngle must be"),
    ({"type": "point", "intensity": 0}, r"intensity is zero"),
])
def test_bad_gltf_lights_are_one_line(tmp_path, light, pattern):
    from .test_gltf import small_scene

    b = small_scene()
    b.doc["extensions"] = {"KHR_lights_punctual": {"lights": [light]}}
    b.node(extensions={"KHR_lights_punctual": {"light": 0}})
    with pytest.raises(SceneError) as err:
        load_scene(b.write_gltf(tmp_path / "l.gltf"))
    msg = str(err.value)
    assert "\n" not in msg and "l.gltf" in msg and re.search(pattern, msg), msg


def test_envmap_is_mapped_with_its_file_scale_and_rotation(tmp_path):
    from .test_environment import write_exr

    write_exr(tmp_path / "sky.exr", np.ones((4, 8, 3), np.float32))
    path = write_xml(tmp_path, SPHERE + """
<emitter type="envmap">
  <string name="filename" value="sky.exr"/><float name="scale" value="2.5"/>
  <transform name="to_world"><rotate y="1" angle="90"/></transform>
</emitter>""")
    env = load_scene(path).environment
    assert env.file == tmp_path / "sky.exr" and env.scale == 2.5 and env.radiance is None
    np.testing.assert_allclose(env.transform.matrix()[:3, :3] @ [1, 0, 0], [0, 0, -1], atol=1e-12)
    bad = write_xml(tmp_path, SPHERE + '<emitter type="envmap"><string name="filename" value="no.exr"/></emitter>',
                    name="bad.xml")
    with pytest.raises(SceneError, match=r"environment map not found"):
        load_scene(bad)

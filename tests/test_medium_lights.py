"""Issue #25: a medium behind an index-matched boundary (a dielectric of ior 1, Mitsuba's null BSDF)
with a delta light (point, spot, directional without a disk) is refused with one located line: mcpt's
shadow rays stop at the boundary, so the light would neither light the medium nor shine through it
(Mitsuba's volpath passes null BSDFs). Lights that rays can reach across it, glass boundaries
(Mitsuba's dielectric blocks shadow rays too) and unused materials load."""

from __future__ import annotations

import pytest

from mcpt.scene import SceneError, load_scene

from .conftest import ROOT
from .test_farm import invoke

SMOKE = ROOT / "bench" / "scenes-xml" / "media-smoke-sphere.xml"
POINT = "{type: point, position: [0, 3, 0], intensity: [5, 5, 5]}"
SPOT = "{type: spot, position: [0, 3, 0], look_at: [0, 0, 0], intensity: [5, 5, 5]}"
SUN = "{type: directional, direction: [0, -1, 0], irradiance: [2, 2, 2]}"
DISK = "{type: directional, direction: [0, -1, 0], irradiance: [2, 2, 2], angular_diameter_deg: 2}"


def yaml_scene(tmp_path, ior: float, light: str | None, used: bool = True):
    lights = f"lights:\n  - {light}\n" if light else "environment: {radiance: [1, 1, 1]}\n"
    path = tmp_path / "scene.yaml"
    path.write_text(f"""camera: {{position: [0, 0, 4], look_at: [0, 0, 0], vfov_deg: 40, resolution: [8, 8]}}
materials:
  floor: {{albedo: [0.5, 0.5, 0.5]}}
  smoke: {{type: dielectric, ior: {ior}, interior: {{albedo: 0.9, density: 2}}}}
meshes:
  - {{shape: sphere, material: {'smoke' if used else 'floor'}}}
{lights}""")
    return path


@pytest.mark.parametrize("light,kind", [(POINT, "point"), (SPOT, "spot"), (SUN, "directional")])
def test_delta_light_and_ior_1_interior_is_one_located_line(tmp_path, light, kind):
    path = yaml_scene(tmp_path, 1.0, light)
    with pytest.raises(SceneError) as exc:
        load_scene(path)
    text = str(exc.value)
    assert "\n" not in text and text.startswith(
        f"{path}:4: materials.smoke.interior: the {kind} light (lights[0]) cannot cross this ior-1 boundary"), text
    assert "emissive mesh, an environment or a sun disk" in text, text


@pytest.mark.parametrize("ior,light,used", [(1.0, DISK, True), (1.0, None, True), (1.5, POINT, True),
                                             (1.0, POINT, False)])
def test_what_renders_right_loads(tmp_path, ior, light, used):
    """A sun disk or an environment (reached by phase samples across the boundary), glass (blocks
    shadow rays in Mitsuba too), an ior-1 medium no mesh uses."""
    sc = load_scene(yaml_scene(tmp_path, ior, light, used))
    assert sc.materials["smoke"].interior is not None


def test_cli_exits_2_and_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    yaml_scene(tmp_path, 1.0, POINT)
    r = invoke("scene.yaml", "-o", "out.exr")
    assert r.exit_code == 2, r.output
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and ":4: materials.smoke.interior: the point light" in lines[0], lines
    assert not (tmp_path / "out.exr").exists()


def xml_with(tmp_path, emitter: str):
    """The shipped smoke-sphere scene (null BSDF around a medium) with ``emitter`` for its sky."""
    text = SMOKE.read_text()
    start = text.index('<emitter type="constant">')
    end = text.index("</emitter>", start) + len("</emitter>")
    path = tmp_path / "smoke.xml"
    path.write_text(text[:start] + emitter + text[end:])
    return path, text[:start].count("\n") + 1


def test_xml_null_bsdf_with_a_point_emitter_is_refused_at_the_shape(tmp_path, monkeypatch):
    point = ('<emitter type="point"><point name="position" x="0" y="3" z="0"/>'
             '<rgb name="intensity" value="5"/></emitter>')
    path, emitter_line = xml_with(tmp_path, point)
    shape_line = next(i + 1 for i, line in enumerate(SMOKE.read_text().splitlines()) if '<shape type="sphere">' in line)
    with pytest.raises(SceneError) as exc:
        load_scene(path)
    text = str(exc.value)
    assert "\n" not in text and text.startswith(
        f'{path}:{shape_line}: <shape type="sphere">: <ref name="interior"> (null BSDF): the point light '
        f"(<emitter>, line {emitter_line}) cannot cross this ior-1 boundary"), text
    monkeypatch.chdir(tmp_path)
    r = invoke("smoke.xml", "-o", "out.exr")
    errors = [line for line in r.stderr.strip().splitlines() if not line.startswith("mcpt: warning:")]
    assert r.exit_code == 2 and len(errors) == 1 and '<ref name="interior"> (null BSDF)' in errors[0], r.output
    assert not (tmp_path / "out.exr").exists()


def test_shipped_media_scenes_still_load():
    for path in sorted((ROOT / "bench" / "scenes-xml").glob("media-*.xml")):
        assert load_scene(path).materials or load_scene(path).medium is not None

"""glTF node animation (issue #26): TRS channels read into mesh tracks, evaluated as the spec says."""

import math

import numpy as np
import pytest

from mcpt.scene import load_scene
from mcpt.scene.diagnostics import SceneError
from mcpt.scene.frame import at_frame
from mcpt.scene.keyframes import quat_matrix

from .gltf_files import QUAD, QUAD_FACES, GltfBuilder


def zquat(deg):
    h = math.radians(deg) / 2
    return [0.0, 0.0, math.sin(h), math.cos(h)]


def animated(tmp_path, interpolation="LINEAR", target=None):
    """A parent node (translated, scaled) with an animated child quad: rotation about z 0 -> 90
    degrees over 0..1 s, translation keys at 0 and 0.5 s; a camera at z = 4."""
    b = GltfBuilder()
    b.node(camera=b.camera(math.radians(45), 1.0), translation=[0, 0, 4])
    child = b.node(root=False, mesh=b.mesh(QUAD, QUAD_FACES), scale=[0.5, 0.5, 0.5])
    b.node(translation=[0.2, 0.1, -1.0], scale=[2, 2, 2], children=[child])
    times = b.accessor(np.array([0.0, 1.0], np.float32))
    rot = b.accessor(np.array([zquat(0), zquat(90)], np.float32))
    t_times = b.accessor(np.array([0.0, 0.5], np.float32))
    move = b.accessor(np.array([[0, 0, 0], [0.4, 0, 0]], np.float32))
    b.doc["animations"] = [{
        "samplers": [{"input": times, "output": rot, "interpolation": interpolation},
                     {"input": t_times, "output": move}],
        "channels": [{"sampler": 0, "target": {"node": child if target is None else target, "path": "rotation"}},
                     {"sampler": 1, "target": {"node": child, "path": "translation"}}]}]
    return b.write_gltf(tmp_path / "anim.gltf")


def spec_world(t):
    """parent * T(t) R(t) S, evaluated as the glTF spec says (lerp, slerp)."""
    parent = np.diag([2.0, 2.0, 2.0, 1.0])
    parent[:3, 3] = [0.2, 0.1, -1.0]
    local = np.eye(4)
    local[:3, :3] = quat_matrix(zquat(90 * min(t, 1.0))) * 0.5
    local[:3, 3] = [0.4 * min(t / 0.5, 1.0), 0, 0]
    return parent @ local


def test_gltf_trs_channels_move_the_mesh_as_the_spec_says(tmp_path):
    scene = load_scene(animated(tmp_path))
    anim = scene.animation
    assert anim.fps == 24 and anim.frames == (0, 24) and len(anim.meshes) == 1
    rest = scene.meshes[0].transform.matrix()
    np.testing.assert_allclose(rest, spec_world(0.0), atol=1e-7)  # the still: the rest pose
    for frame in (0, 3, 6, 12, 18, 24, 30):
        got = at_frame(scene, frame).meshes[0].transform.matrix()
        np.testing.assert_allclose(got, spec_world(frame / 24), atol=1e-6)


@pytest.mark.parametrize("kwargs, needles", [
    ({"interpolation": "STEP"}, ["animations[0].samplers[0]", "STEP"]),
    ({"target": 0}, ["nodes[0]", "places no mesh"]),
    ({"target": 2}, ["nodes[1]", "under animated nodes[2]"]),
])
def test_gltf_animation_refusals_are_one_line(tmp_path, kwargs, needles):
    with pytest.raises(SceneError) as err:
        load_scene(animated(tmp_path, **kwargs))
    msg = str(err.value)
    assert "\n" not in msg and "anim.gltf" in msg
    for n in needles:
        assert n in msg, (n, msg)

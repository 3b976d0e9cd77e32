"""Animation (issue #26): keyframe interpolation, the scene at a frame, sequences and their CLI."""

import math

import numpy as np
import pytest
from click.testing import CliRunner

from mcpt.api import render as render_still
from mcpt.cli.main import main
from mcpt.output.image import read_exr
from mcpt.render import Options
from mcpt.scene import load_scene
from mcpt.scene.diagnostics import SceneError
from mcpt.scene.frame import at_frame, frame_seed
from mcpt.scene.keyframes import Track, euler_quat, quat_matrix, slerp
from mcpt.sequence import SequenceError, frame_path, parse_frames, render_sequence

from .conftest import ROOT

ORBIT = ROOT / "scenes" / "cornell-orbit.yaml"
SMALL = dict(spp=16, resolution=(24, 24))


# ---- interpolation ------------------------------------------------------------------------------

KEY_FRAMES = [1.0, 4.0, 5.0, 11.0]
KEY_VALUES = np.array([[0.1, -2.0, 3.0], [1.7, 0.3, -0.2], [2.2, 2.9, 0.05], [-1.3, 0.4, 7.0]])


@pytest.mark.parametrize("mode", ["linear", "smooth"])
def test_every_key_is_hit_exactly(mode):
    t = Track.make(KEY_FRAMES, KEY_VALUES, mode)
    for f, v in zip(KEY_FRAMES, KEY_VALUES):
        assert np.array_equal(t.at(f), v), (f, t.at(f), v)
    rng = np.random.default_rng(3)
    quats = rng.standard_normal((4, 4))
    q = Track.make(KEY_FRAMES, quats, mode, rotation=True)
    for f, key in zip(KEY_FRAMES, q.values):
        assert np.array_equal(t.at(f), t.at(f))
        assert np.array_equal(q.at(f), key)
        # q and -q are one rotation: the matrix of the key as given, bit for bit
    for f, given in zip(KEY_FRAMES, quats / np.linalg.norm(quats, axis=1, keepdims=True)):
        np.testing.assert_array_equal(quat_matrix(q.at(f)), quat_matrix(given))


def test_outside_the_keys_holds_the_first_and_last():
    t = Track.make(KEY_FRAMES, KEY_VALUES, "smooth")
    assert np.array_equal(t.at(-5.0), KEY_VALUES[0]) and np.array_equal(t.at(99.0), KEY_VALUES[-1])


def test_linear_is_the_chord_and_catmull_rom_keeps_a_straight_line():
    t = Track.make([0.0, 2.0], [[0.0, 0.0, 0.0], [2.0, 4.0, -6.0]], "linear")
    np.testing.assert_allclose(t.at(0.5), [0.5, 1.0, -1.5])
    # Catmull-Rom reproduces motion at constant velocity (keys on a line, any spacing)
    frames = [0.0, 1.0, 3.0, 7.0]
    line = [[2 * f, -f, 0.5 * f] for f in frames]
    s = Track.make(frames, line, "smooth")
    for f in np.linspace(0.0, 7.0, 29):
        np.testing.assert_allclose(s.at(f), [2 * f, -f, 0.5 * f], atol=1e-12)


def test_slerp_turns_at_constant_speed():
    a, b = euler_quat((0.0, 0.0, 0.0)), euler_quat((0.0, 90.0, 0.0))
    for s in (0.25, 0.5, 0.8):
        q = slerp(a, b, s)
        assert abs(np.linalg.norm(q) - 1.0) < 1e-12
        np.testing.assert_allclose(quat_matrix(q), quat_matrix(euler_quat((0.0, 90.0 * s, 0.0))),
                                   atol=1e-12)


def test_squad_stays_unit_and_on_a_single_axis_matches_slerp():
    # keys about one axis at uniform spacing: squad's inner points lie on the same great circle
    keys = [euler_quat((0.0, d, 0.0)) for d in (0.0, 30.0, 60.0, 90.0)]
    s = Track.make([0.0, 1.0, 2.0, 3.0], keys, "smooth", rotation=True)
    for f in np.linspace(0.0, 3.0, 13):
        q = s.at(f)
        assert abs(np.linalg.norm(q) - 1.0) < 1e-12
        np.testing.assert_allclose(quat_matrix(q), quat_matrix(euler_quat((0.0, 30.0 * f, 0.0))),
                                   atol=1e-9)


def test_euler_quaternion_agrees_with_the_transform_convention():
    from mcpt.scene.transform import Transform

    angles = (20.0, -35.0, 70.0)
    np.testing.assert_allclose(quat_matrix(euler_quat(angles)),
                               Transform(rotate_deg=angles).matrix()[:3, :3], atol=1e-12)


# ---- the scene at a frame -----------------------------------------------------------------------

def test_at_frame_hits_the_scene_keys_and_keeps_the_origin():
    scene = load_scene(ORBIT)
    keys = scene.animation.camera.keys
    for key in keys:
        cam = at_frame(scene, int(key.frame)).camera
        assert cam.position == key.position
    assert at_frame(scene, 48).camera.vfov_deg == 34.0
    assert at_frame(scene, 0).camera.position == keys[0].position      # before the keys: hold
    assert at_frame(scene, 500).camera.position == keys[-1].position   # after: hold
    assert at_frame(scene, 30).origin == scene.camera.position
    assert at_frame(scene, 7).render.seed == frame_seed(scene.render.seed, 7) != scene.render.seed
    m1, m48 = (at_frame(scene, f).meshes[4].transform.matrix() for f in (1, 48))
    assert np.array_equal(m1, scene.meshes[4].transform.matrix())
    np.testing.assert_allclose(m48[:3, :3], quat_matrix(euler_quat((0, 40, 0))), atol=1e-15)
    assert m48[1, 3] == 0.1


def write_scene(tmp_path, animation: str):
    text = ORBIT.read_text().split("\nanimation:")[0].replace("cornell/", str(ROOT / "scenes" / "cornell") + "/")
    p = tmp_path / "anim.yaml"
    p.write_text(text + "\nanimation:\n" + animation)
    return p


@pytest.mark.parametrize("animation, needles", [
    ("  camera:\n    keys:\n      - {frame: 5, position: [0, 0, 4]}\n      - {frame: 2, position: [0, 0, 3]}\n",
     ["animation.camera.keys.1.frame", "must increase"]),
    ("  meshes:\n    - mesh: 9\n      keys:\n        - {frame: 1, translate: [0, 0, 0]}\n",
     ["animation.meshes.0.mesh", "no mesh 9"]),
    ("  frames: [5, 2]\n", ["animation.frames"]),
    ("  camera:\n    keys:\n      - {frame: 1, focus_distance: 2}\n",
     ["animation.camera.keys.0.focus_distance", "needs a thin lens"]),
    ("  camera:\n    interpolation: cubic\n    keys:\n      - {frame: 1, position: [0, 0, 4]}\n",
     ["animation.camera.interpolation"]),
])
def test_bad_animation_is_one_located_line(tmp_path, animation, needles):
    with pytest.raises(SceneError) as err:
        load_scene(write_scene(tmp_path, animation))
    msg = str(err.value)
    assert "\n" not in msg and "anim.yaml:" in msg
    line = int(msg.split("anim.yaml:")[1].split(":")[0])
    assert line > 40  # the animation block, at the end of the file
    for n in needles:
        assert n in msg, (n, msg)


def test_frames_and_patterns():
    assert parse_frames("1,5,10-12") == [1, 5, 10, 11, 12]
    assert parse_frames("3-3,3") == [3]
    for bad in ("", "1-", "a", "5-2", "-3"):
        with pytest.raises(SequenceError):
            parse_frames(bad)
    assert str(frame_path("out/shot.####.exr", 7)) == "out/shot.0007.exr"
    assert str(frame_path("out/v#_#####.png", 123456)) == "out/v#_123456.png"


# ---- sequences on the GPU -----------------------------------------------------------------------

def still(scene, frame, path):
    """A still render of the scene at ``frame`` (fresh prepare), as a user would make it."""
    render_still(at_frame(scene, frame), Options([str(path)]))
    return read_exr(path)[0]


LENS = ("camera.lens={focus_distance: 3.9, aperture_radius: 0.08}", "camera.vfov_deg=null",
        "camera.fov_deg=45", "camera.filter={type: gaussian}")
RACK_FOCUS = "animation.camera.keys=[{frame: 1, position: [-1.2, 0.3, 3.7], focus_distance: 2.5}, " \
             "{frame: 40, position: [1.2, -0.2, 3.7], focus_distance: 4.5}]"


@pytest.mark.parametrize("meshes", ["moving", "still", "lens"])
def test_frame_n_of_a_sequence_is_the_still_at_n(tmp_path, meshes):
    over = (*LENS, RACK_FOCUS, "animation.meshes=[]") if meshes == "lens" else ()
    scene = load_scene(ORBIT, overrides=over).with_overrides(**SMALL)
    if meshes == "still":
        scene = scene.model_copy(update={"animation": scene.animation.model_copy(update={"meshes": ()})})
    out = render_sequence(scene, Options([str(tmp_path / "f.##.exr")]), [1, 9, 30])
    assert [r.frame for r in out.rendered] == [1, 9, 30] and out.rebuilt == (meshes == "moving")
    if meshes == "lens":  # the lens keys reach the camera; a keyless vfov still follows fov_deg
        cam = at_frame(scene, 9).camera
        assert cam.lens.focus_distance == pytest.approx(2.5 + 2.0 * 8 / 39, abs=1e-12) and cam.fov_deg == 45
    frames = {f: read_exr(tmp_path / f"f.{f:02d}.exr")[0] for f in (1, 9, 30)}
    assert not np.array_equal(frames[1], frames[9])
    for f in (9, 30):  # frames after the first reuse the prepared scene (camera) or rebuild it
        np.testing.assert_array_equal(frames[f], still(scene, f, tmp_path / f"still{f}.exr"))


def test_progress_counts_paths_of_every_pixel_in_a_sequence(tmp_path):
    """paths/s of a frame is pixels x passes / s (a sequence calls run() alone: it used to report
    passes/s under the paths/s label)."""
    class Record:
        pixels = 1

        def __call__(self, done, total, run, seconds):
            self.seen = (done, total)

    rec = Record()
    scene = load_scene(ORBIT).with_overrides(**SMALL)
    render_sequence(scene, Options([str(tmp_path / "p.#.exr")], progress=rec), [2])
    assert rec.pixels == scene.camera.width * scene.camera.height > 1 and rec.seen[0] == rec.seen[1]


def test_a_rerun_renders_only_what_is_missing(tmp_path):
    scene = load_scene(ORBIT).with_overrides(**SMALL)
    pattern = str(tmp_path / "s.####.exr")
    first = render_sequence(scene, Options([pattern]), [2, 3, 4])
    assert [r.frame for r in first.rendered] == [2, 3, 4]
    before = (tmp_path / "s.0003.exr").read_bytes()
    (tmp_path / "s.0004.exr").unlink()
    (tmp_path / "s.0002.exr.state.npz").write_bytes(b"partial")  # a checkpoint: frame 2 unfinished
    again = render_sequence(scene, Options([pattern]), [2, 3, 4])
    assert [r.frame for r in again.rendered] == [2, 4] and again.skipped == [3]
    assert (tmp_path / "s.0003.exr").read_bytes() == before
    assert not (tmp_path / "s.0002.exr.state.npz").exists()


def invoke(*args):
    return CliRunner().invoke(main, ["render", *args, "--quiet"], catch_exceptions=False)


def test_cli_sequence_writes_frames_with_their_metadata(tmp_path):
    r = invoke(str(ORBIT), "--frames", "3,5", "--spp", "8", "--resolution", "16x16",
               "-o", str(tmp_path / "c.###.exr"), "-o", str(tmp_path / "c.###.png"))
    assert r.exit_code == 0, r.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.003.exr", "c.003.png", "c.005.exr", "c.005.png"]
    _, header = read_exr(tmp_path / "c.005.exr")
    assert int(header["mcpt:frame"]) == 5 and math.isclose(float(header["mcpt:fps"]), 24.0)
    assert int(header["mcpt:seed"]) == frame_seed(0, 5)


@pytest.mark.parametrize("args, needles", [
    (["--frames", "1-3", "-o", "{d}/plain.exr"], ["plain.exr", "'#'"]),
    (["--frames", "2-1", "-o", "{d}/s.#.exr"], ["--frames", "backwards"]),
    (["--frames", "1", "-o", "{d}/file.txt/s.#.exr"], ["cannot write"]),
])
def test_cli_bad_sequences_exit_2_and_write_nothing(tmp_path, args, needles):
    (tmp_path / "file.txt").write_text("a file, not a folder")
    r = invoke(str(ORBIT), "--spp", "4", "--resolution", "8x8", *[a.format(d=tmp_path) for a in args])
    assert r.exit_code == 2, r.output
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("mcpt: error:"), lines
    for n in needles:
        assert n in lines[0], (n, lines[0])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file.txt"]


# ---- on Dask ------------------------------------------------------------------------------------

def test_a_farm_sequence_equals_the_one_process_sequence(tmp_path):
    """Two workers, one task per frame; one worker killed (SIGKILL) when the first frame arrives:
    its frame is retried elsewhere and every frame is the one-process frame, bit for bit."""
    pytest.importorskip("distributed")
    import os
    import signal

    from distributed import Client

    from mcpt.farm.cluster import local_cluster
    from mcpt.farm.frames import sequence_on_cluster

    frames = [4, 5, 6, 7, 8, 30]
    opts = dict(spp=16, resolution=(20, 20), seed=3)
    one = render_sequence(ORBIT, Options([str(tmp_path / "one.##.exr")], **opts), frames)
    (tmp_path / "farm.05.exr").write_bytes((tmp_path / "one.05.exr").read_bytes())  # done already
    cluster = local_cluster(2, lp_threads=1)
    killed = []
    try:
        with Client(cluster) as client:
            def kill_one(rep):
                if not killed:
                    victim = sorted(client.run(os.getpid).values())[0]
                    os.kill(victim, signal.SIGKILL)
                    killed.append(victim)

            farm = sequence_on_cluster(ORBIT, Options([str(tmp_path / "farm.##.exr")], client=client,
                                                      **opts), frames, on_frame=kill_one)
    finally:
        cluster.close()
    assert killed
    assert [r.frame for r in farm.rendered] == [4, 6, 7, 8, 30] and farm.skipped == [5]
    assert [r.seed for r in farm.rendered] == [r.seed for r in one.rendered if r.frame != 5]
    for f in (4, 6, 7, 8, 30):
        np.testing.assert_array_equal(read_exr(tmp_path / f"farm.{f:02d}.exr")[0],
                                      read_exr(tmp_path / f"one.{f:02d}.exr")[0])


# ---- video --------------------------------------------------------------------------------------

def test_render_to_mp4_and_encode_frames(tmp_path):
    ffmpeg = pytest.importorskip("imageio_ffmpeg")
    r = invoke(str(ORBIT), "--frames", "1-4", "--spp", "8", "--resolution", "33x24",
               "-o", str(tmp_path / "a.mp4"), "-o", str(tmp_path / "a.##.png"))
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, ["encode", str(tmp_path / "a.##.png"), "-o", str(tmp_path / "b.mp4"),
                                  "--fps", "12"], catch_exceptions=False)
    assert r.exit_code == 0, r.output
    import cv2

    pngs = [cv2.imread(str(tmp_path / f"a.{f:02d}.png"))[..., ::-1].astype(np.float64) for f in range(1, 5)]
    for name, fps in (("a.mp4", 24.0), ("b.mp4", 12.0)):
        reader = ffmpeg.read_frames(str(tmp_path / name))
        meta = next(reader)
        assert meta["size"] == (34, 24) and meta["fps"] == fps  # odd width padded, not scaled
        frames = [np.frombuffer(b, np.uint8).reshape(24, 34, 3)[:, :33] for b in reader]
        assert len(frames) == 4
        for got, png in zip(frames, pngs):  # H.264 is lossy: close to the PNG tone mapping
            assert np.abs(got - png).mean() < 6.0, np.abs(got - png).mean()


def test_video_without_ffmpeg_is_one_line(tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)
    r = invoke(str(ORBIT), "--frames", "1-2", "--spp", "4", "--resolution", "8x8", "-o",
               str(tmp_path / "v.mp4"))
    assert r.exit_code == 2
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "pip install 'mcpt[video]'" in lines[0], lines
    assert not list(tmp_path.iterdir())


def test_time_budget_stops_between_frames_and_a_rerun_finishes(tmp_path, monkeypatch):
    import itertools
    import types

    import mcpt.sequence

    scene = load_scene(ORBIT).with_overrides(**SMALL)
    pattern = str(tmp_path / "t.#.exr")
    render_sequence(scene, Options([pattern]), [1])
    # A clock that says 1 s passes between any two readings of it in mcpt/sequence.py: frame 2
    # starts (1 s used of 5, no frame timed yet), takes 2 s; 5 s used + 2 s > 5: frame 3 does not
    ticks = itertools.count(1.0)
    monkeypatch.setattr(mcpt.sequence, "time", types.SimpleNamespace(perf_counter=lambda: next(ticks)))
    cut = render_sequence(scene, Options([pattern], time_budget=5.0, started=0.0), [1, 2, 3])
    assert [r.frame for r in cut.rendered] == [2] and cut.stopped_by == "time" and cut.skipped == [1]
    assert not (tmp_path / "t.3.exr").exists()
    monkeypatch.undo()
    rest = render_sequence(scene, Options([pattern], time_budget=3600), [1, 2, 3])
    assert [r.frame for r in rest.rendered] == [3] and rest.skipped == [1, 2] and rest.stopped_by is None


def test_a_single_farm_frame_spreads_its_pass_ranges(tmp_path):
    """One frame left: its passes go out as pass-range tasks whose workers prepare the scene at
    that frame (the job names it); the frame equals the one-process frame bit for bit."""
    pytest.importorskip("distributed")
    from distributed import Client

    from mcpt.farm.cluster import local_cluster
    from mcpt.farm.frames import sequence_on_cluster

    opts = dict(spp=64 * 3, resolution=(16, 16), seed=5)
    render_sequence(ORBIT, Options([str(tmp_path / "one.#.exr")], **opts), [7])
    cluster = local_cluster(2, lp_threads=1)
    try:
        with Client(cluster) as client:
            farm = sequence_on_cluster(ORBIT, Options([str(tmp_path / "farm.#.exr")], client=client,
                                                      **opts), [7])
            # pass-range tasks prepare the job on the workers (worker.py); frame tasks use _MAKERS
            held = client.run(_farm_state)
    finally:
        cluster.close()
    assert [r.frame for r in farm.rendered] == [7]
    assert sum(n for n, _ in held.values()) >= 1 and all(m == 0 for _, m in held.values()), held
    np.testing.assert_array_equal(read_exr(tmp_path / "farm.7.exr")[0], read_exr(tmp_path / "one.7.exr")[0])


def _farm_state():
    from mcpt.farm import frames, worker

    return len(worker._PREPARED), len(frames._MAKERS)


@pytest.mark.parametrize("args, needles", [
    (["{d}/none.####.png", "-o", "{d}/v.mp4"], ["none.####.png", "no frames found"]),
    (["{d}/a.png", "-o", "{d}/v.avi"], ["v.avi", "use .mp4"]),
])
def test_encode_bad_input_is_one_line(tmp_path, args, needles):
    pytest.importorskip("imageio_ffmpeg")
    import cv2

    cv2.imwrite(str(tmp_path / "a.png"), np.zeros((4, 4, 3), np.uint8))
    r = CliRunner().invoke(main, ["encode", *[a.format(d=tmp_path) for a in args]], catch_exceptions=False)
    assert r.exit_code == 2, r.output
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("mcpt: error:"), lines
    for n in needles:
        assert n in lines[0], (n, lines[0])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png"]

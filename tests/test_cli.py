"""Bad input on the command line (issue #6): every case exits non-zero with ONE line that names the
file, line or key (or warns, where stated), and never leaves an image at the output path; an image
already there stays untouched.

Most cases run in process through click's CliRunner (the GL context is shared, so each costs
milliseconds); two run the installed `mcpt` script in a subprocess, as a user would.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from mcpt.cli.main import main

from .conftest import ROOT

FLOOR_OBJ = "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 3 2\nf 1 4 3\n"

SCENE = """\
camera:
  position: [0, 1, 0]
  look_at: [0, 0, 0]
  up: [0, 0, -1]
  vfov_deg: 60
  resolution: [4, 4]
render:
  spp: 1
  bounces: 1
materials:
  glow:
    albedo: [0.5, 0.5, 0.5]
    emission: [1, 1, 1]
meshes:
  - file: floor.obj
    material: glow
"""

SENTINEL = b"an image that was here before the failed render"


@pytest.fixture
def folder(tmp_path, monkeypatch):
    """A folder with a valid tiny scene (scene.yaml + floor.obj) as the working directory."""
    (tmp_path / "floor.obj").write_text(FLOOR_OBJ)
    (tmp_path / "scene.yaml").write_text(SCENE)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def invoke(*args: str):
    return CliRunner().invoke(main, ["render", *args, "--quiet"], catch_exceptions=False)


def assert_fails_cleanly(result, folder: Path, *needles: str, output: str = "out.exr",
                         status: int = 2) -> str:
    """Non-zero exit, exactly one stderr line 'mcpt: error: ...' containing every needle, and
    nothing written: no image, no temporary file, the sentinel (if any) byte-identical."""
    assert result.exit_code == status, (result.exit_code, result.output)
    lines = [ln for ln in result.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, lines
    line = lines[0]
    assert line.startswith("mcpt: error:"), line
    for n in needles:
        assert n in line, (n, line)
    target = folder / output
    if target.is_file():  # only the image that was there before may be there now
        assert target.read_bytes() == SENTINEL
    if target.parent.is_dir():
        assert not list(target.parent.glob(f".{target.name}.*"))
    return line


def with_sentinel(folder: Path, name: str = "out.exr") -> Path:
    p = folder / name
    p.write_bytes(SENTINEL)
    return p


# ---- command-line values ------------------------------------------------------------------------

@pytest.mark.parametrize("args, needles", [
    (["--spp", "0"], ["scene.yaml", "render.spp", "greater than or equal to 1"]),
    (["--spp", "-5"], ["scene.yaml", "render.spp"]),
    (["--bounces", "-1"], ["scene.yaml", "render.bounces"]),
    (["--seed", "-1"], ["scene.yaml", "render.seed"]),
    (["--resolution", "0x8"], ["scene.yaml", "camera.resolution"]),
    (["--resolution", "16385x8"], ["camera.resolution", "16384"]),
    (["--resolution", "abc"], ["--resolution", "WIDTHxHEIGHT"]),
    (["--spp", "1e3"], ["--spp", "not a valid integer"]),
    (["--spp", "ten"], ["--spp"]),
    (["--clamp", "0"], ["--clamp", "greater than 0"]),
    (["--clamp", "-1"], ["--clamp"]),
    (["--clamp", "nan"], ["--clamp", "finite"]),
    (["--exposure", "inf"], ["--exposure", "finite"]),
    (["--gl-backend", "vulkan"], ["--gl-backend", "vulkan"]),
    (["--bogus-option"], ["--bogus-option"]),
])
def test_bad_option_values(folder, args, needles):
    with_sentinel(folder)
    assert_fails_cleanly(invoke("scene.yaml", *args, "-o", "out.exr"), folder, *needles)


def test_output_in_a_missing_folder_creates_it(folder):
    """Issue #10: `-o renders/x.exr` (and the default out/render.exr) create the folder."""
    r = invoke("scene.yaml", "-o", "nowhere/deeper/out.exr")
    assert r.exit_code == 0, r.output
    assert (folder / "nowhere" / "deeper" / "out.exr").stat().st_size > 0


def test_output_under_a_file_fails_before_rendering(folder, monkeypatch):
    """A folder that cannot be created or written is reported before the render, one line."""
    from mcpt.gpu import render as render_mod

    (folder / "plain").write_text("a file, not a folder")
    monkeypatch.setattr(render_mod.Renderer, "passes", lambda *a, **k: pytest.fail("rendered"))
    assert_fails_cleanly(invoke("scene.yaml", "-o", "plain/out.exr"), folder, "plain/out.exr",
                         "cannot write", output="plain/out.exr")


def test_unwritable_second_output_writes_nothing_and_renders_nothing(folder, monkeypatch):
    """Issue #10: with two outputs and the second folder unwritable, the first is not written."""
    from mcpt.gpu import render as render_mod

    (folder / "plain").write_text("x")
    with_sentinel(folder)
    monkeypatch.setattr(render_mod.Renderer, "passes", lambda *a, **k: pytest.fail("rendered"))
    assert_fails_cleanly(invoke("scene.yaml", "-o", "out.exr", "-o", "plain/b.exr"), folder,
                         "plain/b.exr", "cannot write")


@pytest.mark.parametrize("name", ["out.jpg", "out", "out.EXRX"])
def test_output_with_an_unknown_extension(folder, name):
    assert_fails_cleanly(invoke("scene.yaml", "-o", name), folder, name, "unknown image format",
                         output=name)


@pytest.mark.parametrize("name", ["dir.exr", "dir"])
def test_output_that_is_a_folder(folder, name):
    (folder / name).mkdir()
    line = assert_fails_cleanly(invoke("scene.yaml", "-o", name), folder, name, "existing folder",
                                output=f"{name}/x")
    assert "unknown image format" not in line


def test_second_output_bad_writes_nothing(folder):
    """Every output path is checked before rendering: the good one is not written either."""
    with_sentinel(folder)
    assert_fails_cleanly(invoke("scene.yaml", "-o", "out.exr", "-o", "b.tiff"), folder, "b.tiff")
    assert not (folder / "b.tiff").exists()


# ---- scene files -----------------------------------------------------------------------------

def scene_with(folder: Path, old: str, new: str, name: str = "bad.yaml") -> str:
    text = SCENE.replace(old, new)
    assert text != SCENE
    (folder / name).write_text(text)
    return name


@pytest.mark.parametrize("old, new, needles", [
    ("  spp: 1\n", "  spp: 1e3\n", ["bad.yaml:8:", "render.spp", "1000"]),          # YAML 1.1: str
    ("  spp: 1\n", "  spp: 1\n  spp: 2\n", ["bad.yaml:9:", "duplicate key 'spp'"]),
    ("  bounces: 1\n", "  bounces: 1\n  bounce: 2\n", ["bad.yaml:10:", "render.bounce", "unknown key"]),
    ("  vfov_deg: 60\n", "  vfov_deg: [60\n", ["bad.yaml:", "malformed YAML"]),
    ("  vfov_deg: 60\n", "  vfov_deg: .nan\n", ["bad.yaml:5:", "camera.vfov_deg"]),
    ("    emission: [1, 1, 1]\n", "    emission: [1, 1, -1]\n", ["bad.yaml:13:", "materials.glow.emission"]),
    ("    material: glow\n", "    material: glo\n", ["bad.yaml:16:", "meshes.0.material", "glo"]),
    ("  - file: floor.obj\n", "  - file: missing.obj\n", ["bad.yaml:15:", "meshes.0.file", "not found"]),
    ("  resolution: [4, 4]\n", "  resolution: [4, 4, 4]\n", ["bad.yaml:6:", "camera.resolution"]),
    ("meshes:\n  - file: floor.obj\n    material: glow\n", "meshes: []\n", ["bad.yaml:14:", "meshes"]),
    ("  up: [0, 0, -1]\n", "  up: [0, 1, 0]\n", ["bad.yaml:4:", "camera.up", "parallel"]),
    ("  position: [0, 1, 0]\n", "  position: [0, 1, 0]\n  position: [0, 2, 0]\n",
     ["bad.yaml:3:", "duplicate key 'position'"]),
])
def test_bad_scene_files(folder, old, new, needles):
    with_sentinel(folder)
    assert_fails_cleanly(invoke(scene_with(folder, old, new), "-o", "out.exr"), folder, *needles)


def test_yaml_11_boolean_key_names_its_line_and_key(folder):
    """`on:` is True in YAML 1.1: the error must still name line 2 and the key as written."""
    (folder / "bad.yaml").write_text("camera: {position: [0, 1, 0], look_at: [0, 0, 0], up: [0, 0, -1],"
                                     " vfov_deg: 60, resolution: [4, 4]}\non: 3\n"
                                     "meshes:\n  - {file: floor.obj}\n")
    assert_fails_cleanly(invoke("bad.yaml", "-o", "out.exr"), folder, "bad.yaml:2: on:", "'on'")


def test_empty_scene_file(folder):
    (folder / "empty.yaml").write_text("")
    assert_fails_cleanly(invoke("empty.yaml", "-o", "out.exr"), folder, "empty.yaml:1:", "empty")


def test_scene_that_is_not_a_mapping(folder):
    (folder / "list.yaml").write_text("- 1\n- 2\n")
    assert_fails_cleanly(invoke("list.yaml", "-o", "out.exr"), folder, "list.yaml", "mapping")


def test_missing_scene_file(folder):
    with_sentinel(folder)
    assert_fails_cleanly(invoke("nope.yaml", "-o", "out.exr"), folder, "nope.yaml", "cannot read")


def test_scene_file_that_is_not_utf8(folder):
    (folder / "latin.yaml").write_bytes(SCENE.encode().replace(b"camera", b"c\xe9mera", 1))
    assert_fails_cleanly(invoke("latin.yaml", "-o", "out.exr"), folder, "latin.yaml", "UTF-8")


# ---- mesh files ------------------------------------------------------------------------------

@pytest.mark.parametrize("obj, needles", [
    ("v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n", ["m.obj:3:", "not finite", "nan"]),
    ("v 0 0 0\nv 1 0 0\nv 0 1 inf\nf 1 2 3\n", ["m.obj:3:", "not finite"]),
    ("v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n", ["m.obj:2:", "not finite"]),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", ["m.obj:4:", "index 9 out of range"]),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", ["m.obj:4:", "index 0 out of range"]),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -7\n", ["m.obj:4:", "index -7 out of range"]),
    ("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", ["m.obj", "no triangles with non-zero area"]),
    ("v 0 0 0\nv 1 0 0\nv 1 1 0\nl 1 2\n", ["m.obj", "only triangles"]),
    ("", ["m.obj", "cannot load"]),
])
def test_bad_meshes(folder, obj, needles):
    (folder / "m.obj").write_text(obj)
    with_sentinel(folder)
    assert_fails_cleanly(invoke(scene_with(folder, "file: floor.obj", "file: m.obj"), "-o", "out.exr"),
                         folder, *needles)


def test_bad_mesh_names_the_scene_line_and_key_too(folder):
    (folder / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 nan\nf 1 2 3\n")
    text = scene_with(folder, "file: floor.obj", "file: m.obj")
    assert_fails_cleanly(invoke(text, "-o", "out.exr"), folder, "bad.yaml:15: meshes.0.file:", "m.obj:3:")


def _textured(folder: Path, texture: str) -> str:
    return scene_with(folder, "    albedo: [0.5, 0.5, 0.5]", f"    albedo_texture: {texture}")


def test_texture_that_is_not_an_image_is_a_user_error(folder):
    """Issue #10: exit 2 (not 'internal error'), naming the scene line and key and the file."""
    (folder / "fake.png").write_text("this is text, not a PNG")
    with_sentinel(folder)
    assert_fails_cleanly(invoke(_textured(folder, "fake.png"), "-o", "out.exr"), folder,
                         "bad.yaml:", "materials.glow.albedo_texture", "fake.png", "cannot read the image")


def test_texture_with_an_unsupported_extension_names_it(folder):
    (folder / "tex.gif").write_bytes(b"GIF89a")
    line = assert_fails_cleanly(invoke(_textured(folder, "tex.gif"), "-o", "out.exr"), folder,
                                "materials.glow.albedo_texture", "'.gif'")
    assert "{" not in line


def test_yaml_alias_bomb_fails_fast_in_one_line(folder):
    """Issue #10: nine levels of nine aliases (9^9 values) must fail in well under a second."""
    import time

    levels = ['&a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for prev, cur in zip("abcdefgh", "bcdefghi"):
        levels.append(f"&{cur} [" + ", ".join([f"*{prev}"] * 9) + "]")
    text = scene_with(folder, "materials:", "name: [" + ", ".join(levels) + "]\nmaterials:")
    t0 = time.perf_counter()
    line = assert_fails_cleanly(invoke(text, "-o", "out.exr"), folder, "bad.yaml", "aliases")
    assert time.perf_counter() - t0 < 1.0
    assert len(line) < 400


def test_misspelt_key_is_named_with_a_suggestion(folder):
    """Issue #10: `fov` for `vfov_deg` names the unknown key and suggests the nearest one (since
    issue #22 `fov_deg`, the field of view along `fov_axis`)."""
    line = assert_fails_cleanly(invoke(scene_with(folder, "  vfov_deg: 60", "  fov: 60"), "-o", "out.exr"),
                                folder, "camera.fov", "unknown key 'fov'", "did you mean 'fov_deg'")
    assert "missing" not in line


def test_huge_value_is_not_echoed_whole(folder):
    name = "x" * 30_000
    line = assert_fails_cleanly(invoke(scene_with(folder, "material: glow", f"material: {name}"), "-o", "out.exr"),
                                folder, "meshes.0.material", "undefined material")
    assert len(line) < 500


def test_internal_error_hint_works_as_typed(folder, monkeypatch):
    """The hint names the place -vv goes (before the command), and doing that shows the traceback."""
    from mcpt.gpu import render as render_mod

    monkeypatch.setattr(render_mod.Renderer, "passes", lambda *a, **k: (_ for _ in ()).throw(ValueError("boom")))
    r = CliRunner().invoke(main, ["render", "scene.yaml", "-o", "out.exr"])
    assert "run 'mcpt -vv render ...'" in r.stderr
    r = CliRunner().invoke(main, ["-vv", "render", "scene.yaml", "-o", "out.exr"])
    assert isinstance(r.exception, ValueError)


def test_unsupported_mesh_format(folder):
    (folder / "m.xyz").write_text("hello world\n")
    with_sentinel(folder)
    assert_fails_cleanly(invoke(scene_with(folder, "file: floor.obj", "file: m.xyz"), "-o", "out.exr"),
                         folder, "m.xyz", "cannot load")


def test_binary_garbage_with_a_mesh_extension(folder):
    (folder / "m.ply").write_bytes(bytes(range(256)) * 4)
    assert_fails_cleanly(invoke(scene_with(folder, "file: floor.obj", "file: m.ply"), "-o", "out.exr"),
                         folder, "m.ply")


def test_transform_beyond_float32(folder):
    bad = scene_with(folder, "    material: glow\n",
                     "    material: glow\n    transform: {translate: [1e39, 0, 0]}\n")
    assert_fails_cleanly(invoke(bad, "-o", "out.exr"), folder, "floor.obj", "float32")


def test_emission_beyond_float32_is_refused(folder):
    bad = scene_with(folder, "    emission: [1, 1, 1]\n", "    emission: [1e39, 1, 1]\n")
    assert_fails_cleanly(invoke(bad, "-o", "out.exr"), folder, "bad.yaml:13:", "materials.glow.emission")


# ---- warnings, not errors --------------------------------------------------------------------

def test_scene_without_lights_warns_and_renders_black(folder):
    from mcpt.output.image import read_exr

    dark = scene_with(folder, "    emission: [1, 1, 1]\n", "    emission: [0, 0, 0]\n")
    r = invoke(dark, "-o", "out.exr")
    assert r.exit_code == 0, r.output
    warn = [ln for ln in r.stderr.splitlines() if "warning" in ln]
    assert len(warn) == 1 and "no emitters" in warn[0] and "bad.yaml" in warn[0], r.stderr
    img, _ = read_exr(folder / "out.exr")
    assert img.shape == (4, 4, 3) and not img.any()


def test_a_good_render_writes_the_image_with_usual_permissions(folder):
    r = invoke("scene.yaml", "-o", "out.exr", "-o", "out.png")
    assert r.exit_code == 0, r.output
    mode = (folder / "out.exr").stat().st_mode & 0o777
    umask = os.umask(0)
    os.umask(umask)
    assert mode == 0o666 & ~umask
    assert (folder / "out.png").stat().st_size > 0
    assert not list(folder.glob(".out.*"))


# ---- failures after rendering started ---------------------------------------------------------

def test_interrupted_render_leaves_no_image(folder, monkeypatch):
    from mcpt.gpu import render as render_mod

    def interrupted(self, *a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(render_mod.Renderer, "passes", interrupted)
    with_sentinel(folder)
    r = invoke("scene.yaml", "-o", "out.exr")
    assert r.exit_code == 130 and r.stderr.strip() == "mcpt: interrupted"
    assert (folder / "out.exr").read_bytes() == SENTINEL


@pytest.mark.parametrize("suffix", [".exr", ".png"])
def test_failed_write_leaves_old_image_and_no_temporary_file(folder, monkeypatch, suffix):
    """The writer dies half-way (disk full): one line, the old image intact, no temporary."""
    import OpenEXR

    def half_written(tmp, *a, **k):
        Path(tmp).write_bytes(b"half an image")
        raise OSError(28, "No space left on device")

    if suffix == ".exr":
        monkeypatch.setattr(OpenEXR.File, "write", lambda self, tmp: half_written(tmp))
    else:  # PNGs are encoded in memory and written by Python (one OSError, no libpng warning)
        from mcpt.output import image

        monkeypatch.setattr(image, "_write_bytes", half_written)
    with_sentinel(folder, "out" + suffix)
    r = invoke("scene.yaml", "-o", "out" + suffix)
    assert r.exit_code == 2, r.output
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and f"out{suffix}" in lines[0] and "No space left" in lines[0], lines
    assert (folder / ("out" + suffix)).read_bytes() == SENTINEL
    assert not list(folder.glob(".out*"))


def test_unexpected_exception_is_one_line_and_no_image(folder, monkeypatch):
    from mcpt.gpu import render as render_mod

    def boom(self, *a, **k):
        raise ValueError("something\nunexpected")

    monkeypatch.setattr(render_mod.Renderer, "passes", boom)
    with_sentinel(folder)
    r = CliRunner().invoke(main, ["render", "scene.yaml", "-o", "out.exr"])
    assert r.exit_code == 1
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "internal error: ValueError: something unexpected" in lines[0]
    assert (folder / "out.exr").read_bytes() == SENTINEL


# ---- the real script ------------------------------------------------------------------------

def mcpt_script() -> list[str]:
    exe = Path(sys.executable).with_name("mcpt")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "mcpt"]


def test_script_refuses_spp_0_with_one_line_and_status_2(folder):
    with_sentinel(folder)
    p = subprocess.run(mcpt_script() + ["render", "scene.yaml", "--spp", "0", "-o", "out.exr"],
                       capture_output=True, text=True, timeout=120, cwd=folder)
    assert p.returncode == 2
    assert p.stderr.strip().splitlines() == [
        "mcpt: error: scene.yaml: render.spp: Input should be greater than or equal to 1 (override)"]
    assert (folder / "out.exr").read_bytes() == SENTINEL


def test_script_renders_and_reports_dropped_samples(folder):
    """A furnace emitting FLT_MAX: every sample overflows, is dropped and counted, and the
    summary says so; the image is written and finite."""
    from mcpt.output.image import read_exr

    (folder / "sphere.obj").write_bytes((ROOT / "scenes/furnace/sphere_inward.obj").read_bytes())
    text = (SCENE.replace("file: floor.obj", "file: sphere.obj")
            .replace("emission: [1, 1, 1]", "emission: [3.4e38, 3.4e38, 3.4e38]")
            .replace("position: [0, 1, 0]", "position: [0, 0, 0]")
            .replace("look_at: [0, 0, 0]", "look_at: [0, 0, -1]").replace("up: [0, 0, -1]", "up: [0, 1, 0]"))
    (folder / "hot.yaml").write_text(text)
    p = subprocess.run(mcpt_script() + ["render", "hot.yaml", "-o", "hot.exr", "--quiet"],
                       capture_output=True, text=True, timeout=120, cwd=folder)
    assert p.returncode == 0, p.stderr
    assert "16 non-finite samples dropped" in p.stderr
    img, _ = read_exr(folder / "hot.exr")
    assert np.isfinite(img).all()


def test_absurd_spp_is_refused_in_one_line(folder):
    """Issue #10: 2^40 spp was accepted and ran until killed; the sample index is 32-bit."""
    assert_fails_cleanly(invoke("scene.yaml", "--spp", str(2**40), "-o", "out.exr"), folder,
                         "render.spp", "4294967295")


def test_a_render_projected_past_an_hour_says_so_first(folder, monkeypatch):
    """Issue #10: the estimate comes after the first draw, before the bulk of the work."""
    from mcpt.farm import control

    monkeypatch.setattr(control, "LONG_RENDER_SECONDS", 0.0)
    r = invoke("scene.yaml", "--spp", "130", "-o", "out.exr")  # more than the first draw's 64
    assert r.exit_code == 0
    warn = [ln for ln in r.stderr.splitlines() if "will take about" in ln]
    assert len(warn) == 1 and "--time SECONDS" in warn[0]

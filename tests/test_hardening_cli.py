"""Issue #24 items 17 and 19: command-line input that was an internal error (exit 1) or a
misleading message. Each case is one line on stderr, exit 2 (or 141 for a closed stdout), and
nothing is written.

Most cases run in process through click's CliRunner; the closed-stdout cases run the installed
`mcpt` script with a pipe whose reader is already gone, as `| head` leaves it.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from mcpt.cli.main import main
from mcpt.farm.worker import FarmError
from mcpt.scene.diagnostics import SceneError
from mcpt.scene.reader import parse_scene

from .conftest import ROOT
from .test_cli import FLOOR_OBJ
from .test_cli import SCENE as CLI_SCENE

# test_cli's scene, its fov written as 4e1: YAML 1.2 reads it as a float (item 19a)
SCENE = CLI_SCENE.replace("vfov_deg: 60", "vfov_deg: 4e1")
assert SCENE != CLI_SCENE

MCPT = str(Path(sys.executable).with_name("mcpt"))


@pytest.fixture
def folder(tmp_path, monkeypatch):
    (tmp_path / "floor.obj").write_text(FLOOR_OBJ)
    (tmp_path / "scene.yaml").write_text(SCENE)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def render(*args: str, env=None):
    return CliRunner(env=env).invoke(main, ["render", "scene.yaml", *args, "--quiet"], catch_exceptions=False)


def one_line(result, code: int = 2) -> str:
    """The single stderr line of a refused command, which wrote nothing."""
    assert result.exit_code == code, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "internal error" not in lines[0] and "Traceback" not in result.output
    return lines[0]


def refused_port() -> int:
    """A local port with nothing listening (bound, then closed)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# --- item 17 ---------------------------------------------------------------------------------

def test_override_with_5000_digits_is_one_line(folder):
    line = one_line(render("-D", "render.spp=" + "1" * 5000, "-o", "a.exr"))
    assert "-D render.spp=" in line and "too long" in line
    assert not (folder / "a.exr").exists()


def test_file_with_5000_digit_integer_is_located():
    text = SCENE.replace("spp: 1", "spp: " + "7" * 5000)
    with pytest.raises(SceneError) as err:
        parse_scene(text, "s.yaml")
    assert err.value.line == 8 and "too long" in str(err.value)


@pytest.mark.parametrize("address", ["tls://127.0.0.1:1", "ucx://127.0.0.1:1", "inproc://x"])
def test_scheduler_scheme_other_than_tcp_is_refused(folder, address):
    pytest.importorskip("distributed")
    line = one_line(render("--scheduler", address, "-o", "a.exr"))
    assert "only tcp://" in line
    assert not (folder / "a.exr").exists()


@pytest.mark.parametrize("value", ["abc", "nan", "-1"])
def test_bad_progress_interval_is_one_line(folder, value):
    result = CliRunner(env={"MCPT_PROGRESS_INTERVAL": value}).invoke(
        main, ["render", "scene.yaml", "-o", "a.exr", "--progress", "plain"], catch_exceptions=False)
    assert "MCPT_PROGRESS_INTERVAL" in one_line(result)
    assert not (folder / "a.exr").exists()


def test_progress_interval_number_is_used(folder):
    result = CliRunner(env={"MCPT_PROGRESS_INTERVAL": "0"}).invoke(
        main, ["render", "scene.yaml", "-o", "a.exr", "--progress", "plain"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert "mcpt: progress 100.0% passes 1/1" in result.stderr


@pytest.mark.parametrize("args", [["--version"], ["--help"], ["render", "--help"],
                                  ["info", "scene.yaml"], ["info", "scene.yaml", "--json"]])
def test_closed_stdout_stops_quietly(folder, args):
    """`mcpt info ... | head`: the reader is gone before mcpt writes (the worst case of a race)."""
    r, w = os.pipe()
    os.close(r)
    try:
        p = subprocess.run([MCPT, *args], stdout=w, stderr=subprocess.PIPE, text=True, timeout=120)
    finally:
        os.close(w)
    assert p.returncode == 141, p.stderr
    assert p.stderr == ""


# --- item 19 ---------------------------------------------------------------------------------

def test_override_reads_floats_as_the_file_does(folder):
    """The file says vfov_deg: 4e1; -D camera.vfov_deg=4e1 must mean the same (YAML 1.2)."""
    result = render("-D", "camera.vfov_deg=4e1", "-D", "materials.glow.albedo=[5e-1,5e-1,.5]", "-o", "a.exr")
    assert result.exit_code == 0, result.output
    from mcpt.output.image import read_exr

    assert render("-o", "b.exr").exit_code == 0
    np.testing.assert_array_equal(read_exr(folder / "a.exr")[0], read_exr(folder / "b.exr")[0])


def test_error_caused_by_an_override_names_it(folder):
    line = one_line(render("-D", "camera.vfov_deg=40", "-D", "materials=", "-o", "a.exr"))
    assert "-D materials=" in line and "undefined material 'glow'" in line
    assert "-D camera.vfov_deg" not in line


def test_error_of_the_file_itself_names_no_override(folder):
    (folder / "scene.yaml").write_text(SCENE.replace("material: glow", "material: nope"))
    line = one_line(render("-D", "camera.vfov_deg=40", "-o", "a.exr"))
    assert "undefined material 'nope'" in line and "-D" not in line


def test_refused_scheduler_is_named_at_once():
    from mcpt.farm.cluster import check_scheduler

    port = refused_port()
    with pytest.raises(FarmError, match="connection refused"):
        check_scheduler(f"tcp://127.0.0.1:{port}")
    with pytest.raises(FarmError, match="out of range"):
        check_scheduler("tcp://127.0.0.1:99999")


def test_refused_scheduler_on_the_command_line(folder):
    pytest.importorskip("distributed")
    line = one_line(render("--scheduler", f"tcp://127.0.0.1:{refused_port()}", "-o", "a.exr"))
    assert "connection refused" in line and "Timed out" not in line
    assert not (folder / "a.exr").exists()


def test_listening_scheduler_address_passes_the_probe():
    from mcpt.farm.cluster import check_scheduler

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        check_scheduler(f"tcp://127.0.0.1:{s.getsockname()[1]}")
        check_scheduler(f"127.0.0.1:{s.getsockname()[1]}")  # Dask's default scheme


def test_empty_scheduler_is_refused(folder):
    pytest.importorskip("distributed")
    assert "empty" in one_line(render("--scheduler", "", "-o", "a.exr"))
    assert not (folder / "a.exr").exists()


def test_workers_with_scheduler_is_refused(folder):
    line = one_line(render("--workers", "2", "--scheduler", "tcp://127.0.0.1:8786", "-o", "a.exr"))
    assert "--workers" in line and "--scheduler" in line
    assert not (folder / "a.exr").exists()


def test_aov_without_exr_output_is_refused(folder):
    line = one_line(render("--aov", "albedo", "-o", "a.png"))
    assert "--aov" in line and "EXR" in line
    assert not (folder / "a.png").exists()


def test_repeated_aov_accumulates(folder):
    from mcpt.output.image import read_exr_channels

    result = render("--aov", "albedo", "--aov", "depth", "-o", "a.exr")
    assert result.exit_code == 0, result.output
    assert {"albedo.R", "albedo.G", "albedo.B", "depth.Z"} <= set(read_exr_channels(folder / "a.exr"))


def test_resume_with_aovs_on_a_plain_checkpoint_says_so(folder):
    assert render("--spp", "2", "--checkpoint", "100", "-o", "a.exr").exit_code == 0
    line = one_line(render("--spp", "4", "--resume", "--aov", "depth", "-o", "a.exr"))
    assert "another version" not in line and "without AOVs" in line


def test_readme_says_resume_after_time_needs_checkpoint():
    text = (ROOT / "README.md").read_text()
    assert "# carry on after a kill or --time" not in text
    assert "Only with `--checkpoint` does a `--time`" in text


def test_time_help_names_checkpoint():
    result = CliRunner().invoke(main, ["render", "--help"])
    help_text = " ".join(result.output.split())
    assert "with --checkpoint it also leaves OUTPUT.state.npz for --resume" in help_text


def test_mcpt_alone_puts_the_error_on_its_own_line():
    result = CliRunner().invoke(main, [], prog_name="mcpt")
    assert result.exit_code == 2
    lines = result.stderr.rstrip("\n").splitlines()
    assert lines[0].startswith("Usage: mcpt")
    assert lines[-1] == "mcpt: error: missing COMMAND (see 'mcpt --help')"
    assert sum("see 'mcpt --help'" in line for line in lines) == 1


def test_output_name_of_250_characters_is_written(folder):
    name = "n" * 246 + ".exr"  # 250 characters: a valid name, too long with mkstemp's affixes
    result = render("-o", name)
    assert result.exit_code == 0, result.output
    assert (folder / name).exists()
    assert [p.name for p in folder.iterdir() if p.name.startswith(".")] == []

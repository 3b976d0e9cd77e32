"""The wheel ships the shaders and the CLI lists its commands (issue #2, part 1)."""

import subprocess
import sys
import zipfile

from click.testing import CliRunner

from cli.main import main

from .conftest import ROOT


def test_wheel_contains_the_shaders_and_finds_them_when_installed(tmp_path):
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                    "-w", str(tmp_path / "dist"), str(ROOT)], check=True, capture_output=True)
    wheel = next((tmp_path / "dist").glob("mcpt-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    shipped = {n.split("/", 2)[-1] for n in names if n.startswith("mcpt/glsl/")}
    on_disk = {p.name for p in (ROOT / "glsl").iterdir() if p.suffix in (".glsl", ".frag", ".vert")}
    assert on_disk and on_disk <= shipped
    assert "cli/main.py" in names
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(target),
                    str(wheel)], check=True, capture_output=True)
    code = ("import mcpt.shader as s, pathlib; d = s.glsl_dir(); "
            "assert str(d).startswith(%r), d; print((d / 'pathtrace.frag').is_file())" % str(target))
    out = subprocess.run([sys.executable, "-I", "-c", f"import sys; sys.path.insert(0, {str(target)!r}); {code}"],
                         cwd=tmp_path, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "True"


def test_help_lists_the_commands():
    result = CliRunner().invoke(main, ["--help"])
    assert result.exit_code == 0
    for command in ("render", "info"):
        assert command in result.output

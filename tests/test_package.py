"""The wheel ships the shaders and the CLI lists its commands (issue #2, part 1)."""

import subprocess
import sys
import zipfile

from click.testing import CliRunner

from mcpt.cli.main import main

from .conftest import ROOT


def test_wheel_is_one_namespace_and_runs_outside_the_source_tree(tmp_path):
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                    "-w", str(tmp_path / "dist"), str(ROOT)], check=True, capture_output=True)
    wheel = next((tmp_path / "dist").glob("mcpt-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    # One namespace: nothing but the mcpt package and its metadata (no top-level cli/ or bench/).
    assert {n.split("/")[0] for n in names} == {"mcpt", wheel.name.split("-py")[0] + ".dist-info"}
    shipped = {n.split("/", 2)[-1] for n in names if n.startswith("mcpt/glsl/")}
    on_disk = {p.name for p in (ROOT / "glsl").iterdir() if p.suffix in (".glsl", ".frag", ".vert")}
    assert on_disk and on_disk <= shipped
    for name in ("mcpt/cli/main.py", "mcpt/bench/suite.py", "mcpt/bench/glsl/probe_trace.frag",
                 "mcpt/scenes/cornell-box.yaml", "mcpt/scenes/cornell/light.obj",
                 "mcpt/scenes/metals.yaml", "mcpt/scenes/models/checker-cube/cube.mtl"):
        assert name in names
    # Every shipped scene file (scenes, meshes, MTLs, textures) is in the wheel.
    scene_files = {"mcpt/scenes/" + str(f.relative_to(ROOT / "scenes")) for f in (ROOT / "scenes").rglob("*")
                   if f.is_file() and "__pycache__" not in f.parts}
    assert scene_files <= set(names), sorted(scene_files - set(names))
    # No verification machinery in the library itself.
    assert not [n for n in names if n.startswith("mcpt/") and not n.startswith(("mcpt/bench/", "mcpt/cli/"))
                and any(w in n for w in ("golden", "stabil", "probe"))]
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(target),
                    str(wheel)], check=True, capture_output=True)
    code = ("import mcpt.gpu.shader as s, mcpt.scene.shipped as sh; d = s.glsl_dir(); "
            "assert str(d).startswith(%r), d; assert str(sh.shipped_dir()).startswith(%r); "
            "print((d / 'pathtrace.frag').is_file())" % (str(target), str(target)))
    run = [sys.executable, "-I", "-c", f"import sys; sys.path.insert(0, {str(target)!r}); {{}}"]
    out = subprocess.run(run[:-1] + [run[-1].format(code)], cwd=tmp_path, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "True"
    # The installed CLI renders a shipped scene and describes it, from outside the source tree.
    scene = target / "mcpt" / "scenes" / "cornell-box.yaml"
    cli = "from mcpt.cli.main import main; main(prog_name='mcpt')"
    for args in (["render", str(scene), "--spp", "2", "--resolution", "8x8", "-o", "x.exr", "--quiet"],
                 ["info", str(scene), "--json", "--resolution", "8x8"]):
        out = subprocess.run(run[:-1] + [run[-1].format(f"sys.argv = ['mcpt'] + {args!r}; {cli}")],
                             cwd=tmp_path, capture_output=True, text=True)
        assert out.returncode == 0, out.stderr
    assert (tmp_path / "x.exr").stat().st_size > 0


def test_help_lists_the_commands():
    result = CliRunner().invoke(main, ["--help"])
    assert result.exit_code == 0
    for command in ("render", "info", "merge"):
        assert command in result.output

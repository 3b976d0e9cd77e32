"""The wheel ships the shaders and the CLI lists its commands (issue #2, part 1)."""

import ast
import re
import subprocess
import sys
import zipfile

import pytest
from click.testing import CliRunner

from mcpt.cli.main import main

from .conftest import ROOT

MAPPED = {"mcpt": "mcpt", "mcpt/cli": "cli", "mcpt/bench": "bench", "mcpt/glsl": "glsl", "mcpt/scenes": "scenes"}


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    dist = tmp_path_factory.mktemp("dist")
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                    "-w", str(dist), str(ROOT)], check=True, capture_output=True)
    return next(dist.glob("mcpt-*.whl"))


def test_wheel_is_one_namespace_and_runs_outside_the_source_tree(tmp_path, wheel):
    names = zipfile.ZipFile(wheel).namelist()
    # One namespace: nothing but the mcpt package and its metadata (no top-level cli/ or bench/).
    assert {n.split("/")[0] for n in names} == {"mcpt", wheel.name.split("-py")[0] + ".dist-info"}
    shipped = {n.split("/", 2)[-1] for n in names if n.startswith("mcpt/glsl/")}
    on_disk = {p.name for p in (ROOT / "glsl").iterdir() if p.suffix in (".glsl", ".frag", ".vert")}
    assert on_disk and on_disk <= shipped
    for name in ("mcpt/cli/main.py", "mcpt/bench/suite.py", "mcpt/bench/glsl/probe_trace.frag",
                 "mcpt/glsl/pathtrace.frag",
                 "mcpt/scenes/cornell-box.yaml", "mcpt/scenes/cornell/light.obj",
                 "mcpt/scenes/metals.yaml", "mcpt/scenes/models/checker-cube/cube.mtl"):
        assert name in names
    # Packages are found, not listed: every module of the five folders ships, at its mapped place.
    modules = {f"{ns}/{f.relative_to(ROOT / d).as_posix()}" for ns, d in MAPPED.items()
               for f in (ROOT / d).rglob("*.py")}
    assert modules and modules <= set(names), sorted(modules - set(names))
    # Every shipped scene file (scenes, meshes, MTLs, textures) is in the wheel.
    scene_files = {"mcpt/scenes/" + str(f.relative_to(ROOT / "scenes")) for f in (ROOT / "scenes").rglob("*")
                   if f.is_file() and "__pycache__" not in f.parts}
    assert scene_files <= set(names), sorted(scene_files - set(names))
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(target),
                    str(wheel)], check=True, capture_output=True)
    code = ("import mcpt.gpu.shader as s, mcpt.scene.shipped as sh; d = s.glsl_dir(); "
            f"assert str(d).startswith({str(target)!r}), d; "
            f"assert str(sh.shipped_dir()).startswith({str(target)!r}); "
            "print((d / 'pathtrace.frag').is_file())")
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


def test_nothing_that_ships_is_verification_machinery(wheel):
    """House rule 2: what ships (mcpt/, cli/, bench/, glsl/, scenes/) holds no test hooks, goldens
    or probes; those live in tests/."""
    with zipfile.ZipFile(wheel) as z:
        files = {n: z.read(n) for n in z.namelist() if n.startswith("mcpt/")}
    # The check itself finds each kind (a test module importing pytest, a module nothing ships
    # imports, a shader outside the renderer's include graph).
    planted = {"mcpt/x/test_a.py": b"import pytest\n", "mcpt/x/hook.py": b"", "mcpt/x/p.frag": b""}
    assert len(verification_machinery({**files, **planted})) == len(verification_machinery(files)) + 5
    bad = verification_machinery(files)
    assert not bad, "\n".join(bad)


def verification_machinery(files: dict[str, bytes]) -> list[str]:
    """What in a wheel's mcpt/ files (name -> bytes) is there for tests, each with why:

    * a test module, fixture file, golden or oracle by name, or golden data (.npz);
    * a module that imports pytest or the tests package;
    * a probe: a shader that neither the renderer's entry shaders (the .frag/.vert of mcpt/glsl/)
      reach through #include nor a shipped module names (``mcpt bench``'s stability suite runs
      bench/glsl/probe_*.frag: a user command's shader, not a test's);
    * a module only tests can use: no shipped module imports it and it is no entry point (the
      console script, a ``__main__``, a module run with ``python -m``, a package's ``__init__``).
    """
    bad = []
    for n in files:
        parts = n.split("/")
        if any(p in ("tests", "test", "conftest.py") or p.startswith(("test_", "golden", "oracle"))
               or p.endswith(("_test.py", ".npz")) for p in parts):
            bad.append(f"{n}: named as test machinery")
    py = {n: ast.parse(src) for n, src in files.items() if n.endswith(".py")}
    modules = {n[:-3].replace("/", ".").removesuffix(".__init__"): n for n in py}
    imported = set()
    for n, tree in py.items():
        mod = n[:-3].replace("/", ".")
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:  # a package's __init__ counts as a module inside it: same rule
                    base = ".".join(mod.split(".")[:-node.level] + ([base] if base else []))
                targets = [base] + [f"{base}.{a.name}" for a in node.names]
            else:
                continue
            for t in targets:
                if t.split(".")[0] in ("pytest", "tests"):
                    bad.append(f"{n}: imports {t}")
                imported.add(t)
    for m, n in modules.items():
        src = files[n].decode()
        entry = (n.endswith(("__init__.py", "__main__.py")) or m == "mcpt.cli.main"
                 or 'if __name__ == "__main__"' in src)
        if not entry and m not in imported:
            bad.append(f"{n}: imported by no shipped module and no entry point (only tests use it?)")
    shaders = {n for n in files if n.endswith((".glsl", ".frag", ".vert"))}
    include = re.compile(rb'^\s*#include\s+"([^"]+)"', re.M)
    reached = set()
    named = b"".join(src for n, src in files.items() if n.endswith(".py"))
    todo = [n for n in shaders if (n.startswith("mcpt/glsl/") and n.endswith((".frag", ".vert")))
            or f'"{n.rsplit("/", 1)[-1]}"'.encode() in named]
    while todo:
        n = todo.pop()
        if n not in reached:
            reached.add(n)
            todo += ["mcpt/glsl/" + m.decode() for m in include.findall(files.get(n, b""))]
    bad += [f"{n}: a shader the renderer never compiles (a probe?)" for n in sorted(shaders - reached)]
    return bad


def test_help_lists_the_commands():
    result = CliRunner().invoke(main, ["--help"])
    assert result.exit_code == 0
    for command in ("render", "info", "merge"):
        assert command in result.output

"""Shader assembly: includes, #line mapping of compiler errors, features <-> defines (issues #2, #4)."""

import re

import pytest

from mcpt.gpu import shader
from mcpt.gpu.features import Features
from mcpt.gpu.shader import ShaderError, Source, glsl_dir


def test_every_feature_define_used_in_glsl_is_declared():
    declared = set(Features.of(bounces=3).defines())
    used = set()
    for path in glsl_dir().iterdir():
        used |= set(re.findall(r"\bMCPT_[A-Z0-9_]+\b", path.read_text()))
    assert used, "no defines found: the scan is broken"
    assert used <= declared, f"used in glsl/ but not emitted by mcpt/gpu/features.py: {used - declared}"


def test_every_define_is_emitted_as_a_number():
    on, off = Features.of(bounces=2).defines(), Features.of(bounces=2, sampling="nee", bvh=False).defines()
    assert on.keys() == off.keys()  # a feature switched off is emitted as 0, never left out
    for value in on.values():
        assert isinstance(value, int) and not isinstance(value, bool)
    assert (on["MCPT_MIS"], off["MCPT_MIS"]) == (1, 0)
    assert (on["MCPT_BVH"], off["MCPT_BVH"]) == (1, 0)


def test_version_comes_first_and_each_file_is_included_once():
    src = Source("pathtrace.frag", Features.of(bounces=2).preamble())
    assert src.text.startswith("#version ")
    assert src.files.count("geometry.glsl") == 1  # included by bvh.glsl only once
    assert "#include" not in "\n".join(ln for ln in src.text.splitlines() if not ln.lstrip().startswith("//"))


def test_compiler_errors_name_the_file_and_line(gl, tmp_path, monkeypatch):
    (tmp_path / "main.frag").write_text('#include "helper.glsl"\nout vec4 o;\nvoid main() { o = f(); }\n')
    (tmp_path / "helper.glsl").write_text("// helper\n\nvec4 f() { return undefined_name; }\n")
    (tmp_path / "fullscreen.vert").write_text((glsl_dir() / "fullscreen.vert").read_text())
    monkeypatch.setattr(shader, "glsl_dir", lambda: tmp_path)
    shader._read.cache_clear()
    try:
        with pytest.raises(ShaderError) as e:
            shader.program(gl.ctx, "fullscreen.vert", "main.frag", "", ("bad",))
    finally:
        shader._read.cache_clear()
    assert "helper.glsl:3" in str(e.value)


def test_a_program_of_the_callers_own_text_includes_the_library_files(gl):
    """program(fragment_text=): the caller's source, glsl/ includes, errors named by its name."""
    text = ('#include "common.glsl"\nout vec4 o;\n'
            "vec4 f() { return vec4(non_finite(1.0) ? 1.0 : 0.0); }\nvoid main() { o = f(); }\n")
    prog = shader.program(gl.ctx, "fullscreen.vert", "mine.frag", "", ("mine",), fragment_text=text)
    assert prog is shader.program(gl.ctx, "fullscreen.vert", "mine.frag", "", ("mine",),
                                  fragment_text=text)
    with pytest.raises(ShaderError) as e:
        shader.program(gl.ctx, "fullscreen.vert", "mine.frag", "", ("mine",),
                       fragment_text=text.replace("vec4(non", "vec2(non"))  # returns a vec2
    assert "mine.frag:3" in str(e.value)
    src = Source("mine.frag", "", text)
    assert src.files[:3] == ["<preamble>", "mine.frag", "common.glsl"]


def test_programs_are_cached_by_feature_key(gl):
    f = Features.of(bounces=1)
    a = shader.program(gl.ctx, "fullscreen.vert", "pathtrace.frag", f.preamble(), f.key)
    b = shader.program(gl.ctx, "fullscreen.vert", "pathtrace.frag", f.preamble(), f.key)
    assert a is b

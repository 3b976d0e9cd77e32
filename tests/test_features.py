"""Leave out what a scene does not need (issue #4): info JSON, data diet, specialised == uber."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from mcpt.api import prepare
from mcpt.cli.main import main
from mcpt.scene import load_scene

from .conftest import ROOT
from .draw import render as draw

CORNELL = ROOT / "scenes" / "cornell-box.yaml"


def test_info_json_reports_counts_features_buffers_and_limits():
    result = CliRunner().invoke(main, ["info", str(CORNELL), "--json", "--bounces", "3"])
    assert result.exit_code == 0, result.output
    info = json.loads(result.output)
    assert info["counts"]["triangles"] == 36
    assert info["counts"]["emissive_triangles"] == 2
    assert info["bvh"]["nodes"] >= 1 and info["bvh"]["depth"] >= 1
    assert info["features"]["defines"]["MCPT_BOUNCES"] == 3
    buffers = info["buffers"]
    assert buffers["tris"] == 36 * 3 * 16  # 3 RGBA32UI texels per triangle
    # The default sampler (sobol) computes its numbers in the shader: nothing is uploaded per pass.
    assert info["features"]["defines"]["MCPT_SAMPLER_SOBOL"] == 1
    assert buffers["random_per_pass"] == 0
    indep = json.loads(CliRunner().invoke(
        main, ["info", str(CORNELL), "--json", "--bounces", "3", "--sampler", "independent"]).output)
    # Independent numbers are sized by the dimensions this bounce count uses.
    dims = indep["features"]["defines"]["MCPT_RAND_DIMS"]
    assert indep["buffers"]["random_per_pass"] == 256 * 256 * dims * 4
    assert info["gl"]["max_texture_buffer_size"] >= 65536
    # A diffuse-only, flat-shaded scene uploads no normals and no UVs.
    assert not {"normals", "uvs", "texels"} & set(buffers)


def test_fewer_bounces_need_fewer_random_numbers():
    a = prepare(CORNELL, bounces=1, resolution=(16, 16), sampler="independent")
    b = prepare(CORNELL, bounces=8, resolution=(16, 16), sampler="independent")
    try:
        assert a.features.random_dims < b.features.random_dims
        assert a.renderer.setup["random_bytes_per_pass"] < b.renderer.setup["random_bytes_per_pass"]
    finally:
        a.renderer.release()
        b.renderer.release()


def test_specialised_and_uber_shader_images_agree_within_noise():
    scene = load_scene(CORNELL).with_overrides(resolution=(48, 48))
    images = []
    for mode in ("scene", "all"):
        p = prepare(scene, features_mode=mode, feature_flags={"variance": True})
        res = draw(p.renderer, 16, seed=3)
        images.append((res.image.astype(np.float64), res.variance.astype(np.float64)))
        p.renderer.release()
    (a, va), (b, vb) = images
    z = np.abs(a - b) / np.sqrt(np.maximum(va + vb, 1e-8))
    assert z.max() < 5.5
    np.testing.assert_allclose(a.mean(), b.mean(), rtol=0.02)


SHIPPED = sorted((ROOT / "scenes").glob("*.yaml"))


@pytest.mark.parametrize("scene_file", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_every_shipped_scene_compiles_only_what_it_uses(scene_file):
    """Each shipped scene's feature combination compiles and renders on this back end (CI runs
    the suite on EGL and on OSMesa), and its shader source holds only the material code it uses."""
    from mcpt.gpu.shader import Source

    p = prepare(scene_file, resolution=(8, 8), bounces=2)
    try:
        res = draw(p.renderer, 1, seed=1)
        assert res.dropped_samples == 0 and np.isfinite(res.image).all()
        text = Source("pathtrace.frag", p.features.preamble()).text
        used = {t for t in p.world.materials.types}
        for kind in ("dielectric", "conductor", "plastic"):
            assert (f"{kind}_sample" in text) == (kind in used), kind
    finally:
        p.renderer.release()


def test_continuation_is_compiled_only_where_a_path_can_outrun_a_draw():
    from mcpt.gpu.features import LLVMPIPE_LOOP_LIMIT, derive, needs_continuation

    # The Cornell box (36 triangles written out, 8 bounces) cannot reach a quarter of llvmpipe's
    # limit in a draw of 64 samples; looping over the same triangles it could.
    assert not needs_continuation(LLVMPIPE_LOOP_LIMIT, 8, 36, traced=False, n_lights=2)
    assert needs_continuation(LLVMPIPE_LOOP_LIMIT, 8, 36, traced=True, n_lights=2)
    assert needs_continuation(LLVMPIPE_LOOP_LIMIT, 1000, 36, traced=False)
    assert needs_continuation(LLVMPIPE_LOOP_LIMIT, 8, 100_000)
    assert not needs_continuation(0, 100_000, 100_000)  # no limit (GPUs): never
    kw = dict(n_emissive=2, material_types={"diffuse"}, loop_limit=LLVMPIPE_LOOP_LIMIT)
    assert derive(bounces=1000, n_triangles=36, **kw).defines()["MCPT_CONTINUE"] == 1
    assert derive(bounces=8, n_triangles=36, **kw).defines()["MCPT_CONTINUE"] == 0
    assert derive(bounces=1000, n_triangles=36, continuation=False, **kw).defines()["MCPT_CONTINUE"] == 0


def test_small_scenes_compile_their_triangle_count_in():
    from mcpt.gpu.features import TRI_CONST_MAX, derive
    kw = dict(bounces=8, n_emissive=2, material_types={"diffuse"})
    assert derive(n_triangles=36, **kw).defines()["MCPT_TRI_CONST"] == 36
    assert derive(n_triangles=TRI_CONST_MAX + 1, bvh=False, **kw).defines()["MCPT_TRI_CONST"] == 0
    assert derive(n_triangles=100_000, **kw).defines()["MCPT_TRI_CONST"] == 0
    # A BVH scene never reads the count; forcing the BVH on a small scene turns it off.
    assert derive(n_triangles=36, bvh=True, **kw).defines()["MCPT_TRI_CONST"] == 0
    assert derive(n_triangles=36, **kw).key != derive(n_triangles=37, **kw).key


def test_samples_per_draw_follow_the_image_size():
    from mcpt.gpu.features import MAX_SAMPLES_PER_DRAW, MIN_SAMPLES_PER_DRAW, PATHS_PER_DRAW, samples_per_draw

    assert samples_per_draw(128, 128) == samples_per_draw(256, 256) == MAX_SAMPLES_PER_DRAW == 64
    assert samples_per_draw(512, 512) == samples_per_draw(800, 600) == 64  # issue #23's headline job
    assert samples_per_draw(1920, 1080) == 16
    assert samples_per_draw(8192, 8192) == MIN_SAMPLES_PER_DRAW  # never fewer than 4
    for w, h in [(1, 1), (64, 64), (300, 200), (800, 600), (1024, 1024), (4096, 4096)]:
        n = samples_per_draw(w, h)
        assert n & (n - 1) == 0 and MIN_SAMPLES_PER_DRAW <= n <= MAX_SAMPLES_PER_DRAW
        assert w * h * n <= PATHS_PER_DRAW or n == MIN_SAMPLES_PER_DRAW
        assert n == MAX_SAMPLES_PER_DRAW or w * h * 2 * n > PATHS_PER_DRAW  # the largest that fits


def test_features_keep_scene_uses_apart_from_options_limits_and_switches():
    """What the scene uses (for_world) is one group; the estimator, the uber-shader and the driver's
    limit are others, and none of them changes what the scene is said to use."""
    from mcpt.gpu.features import LLVMPIPE_LOOP_LIMIT, Features, Switches, for_world
    from mcpt.shapes.world import load_world

    world = load_world(load_scene(CORNELL))
    plain = for_world(world)
    nee = for_world(world, sampling="nee", loop_limit=LLVMPIPE_LOOP_LIMIT)
    uber = plain.everything()
    assert plain.uses == nee.uses == uber.uses  # the Cornell box: diffuse, written out, 2 lights
    assert not plain.uses.conductor and plain.uses.written_out == 36
    assert nee.switches == Switches(sampling="nee") and nee.limits.loop_limit == LLVMPIPE_LOOP_LIMIT
    assert (plain.defines()["MCPT_MIS"], nee.defines()["MCPT_MIS"], nee.defines()["MCPT_NEE"]) == (1, 0, 1)
    # The uber-shader compiles what the scene does not use; its program is another one.
    assert uber.switches.uber and uber.compiled.conductor and uber.defines()["MCPT_MAT_CONDUCTOR"] == 1
    assert uber.key != plain.key and dict(uber.key)["conductor"] and not dict(plain.key)["conductor"]
    # Fields are named alike everywhere; a misspelt one is refused, not ignored.
    assert Features.of(bounces=2, sampling="bsdf", bvh=False).defines()["MCPT_NEE"] == 0
    assert plain.replace(sampling="nee", loop_limit=LLVMPIPE_LOOP_LIMIT) == nee
    with pytest.raises(TypeError, match="sampleing"):
        for_world(world, sampleing="nee")
    with pytest.raises(ValueError, match="sampling"):
        Features.of(bounces=2, sampling="bdsf")


def test_the_joint_sobol_point_is_compiled_only_where_a_second_hit_reads_it():
    from mcpt.gpu.features import derive

    kw = dict(n_emissive=2, material_types={"diffuse"}, n_triangles=36)
    assert derive(bounces=2, **kw).defines()["MCPT_SOBOL_JOINT"] == 1
    assert derive(bounces=1, **kw).defines()["MCPT_SOBOL_JOINT"] == 0
    assert derive(bounces=8, sampler="independent", **kw).defines()["MCPT_SOBOL_JOINT"] == 0
    assert derive(bounces=1, **kw).key != derive(bounces=2, **kw).key

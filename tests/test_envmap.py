"""Environment maps (mcpt/shading/envmap.py, glsl/envmap.glsl): the real GLSL sampling routine
against its own pdf (chi-square, Sidak-corrected), the GLSL against the numpy reference, the pdf's
normalisation over the sphere (poles included), Mitsuba 3's orientation, and bad files."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from mcpt.shading.envmap import (
    LUMINANCE,
    MAX_ENV_TEXELS,
    EnvMapError,
    _cos_fraction,
    _row_weights,
    build_envmap,
    load_envmap,
    read_envmap,
    read_envmap_image,
)
from mcpt.shading.envmap_file import LDR_NOTE

from .probes import run_test_probe
from .test_materials_util import chi2_test, sidak, uniform_numbers

N = 1 << 19
CHI2_TESTS = 5  # two maps x (fine, coarse) histograms, and the bilinear warp's 8 x 8 sub-cells
ALPHA = sidak(0.01, CHI2_TESTS)
# A rotation about +Y by 90 degrees, then a tilt: the maps' to_world in most tests.
_c, _s = math.cos(0.4), math.sin(0.4)
ROT = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]) @ np.array(
    [[1.0, 0.0, 0.0], [0.0, _c, -_s], [0.0, _s, _c]])


def sun_map() -> np.ndarray:
    """128 x 64, radiance 1 with one texel 10^6 in row 1 (next to the north pole): its bilinear
    footprint covers ~1e-5 of the sphere and carries ~80 % of the power."""
    img = np.ones((64, 128, 3), np.float32)
    img[1, 37] = 1e6
    return img


def gradient_map() -> np.ndarray:
    """64 x 32 smooth colour gradient, with black rows (zero-probability rows of cells, whose
    conditional CDF is the uniform fallback) and a black block of columns."""
    y, x = np.mgrid[0:32, 0:64]
    img = np.stack([1.0 + np.sin(x / 10.0) ** 2, 0.2 + y / 31.0, 0.5 + 0.5 * np.cos(y / 5.0)], -1)
    img[20:24] = 0.0
    img[5:12, 40:52] = 0.0
    return (img * 3.0).astype(np.float32)


MAPS = {"sun": sun_map, "gradient": gradient_map}


def probe(gl, env, mode: int, items: np.ndarray) -> np.ndarray:
    """(N, 4) float32 from tests/glsl/probe_envmap.frag (modes in its header)."""
    buf = np.zeros((len(items), 4), np.float32)
    buf[:, : items.shape[1]] = items
    out = run_test_probe(gl, "probe_envmap.frag", buf.view(np.uint32), len(items), key=("probe_envmap",),
                         tbos=env.pack(), uniforms={"u_mode": mode, **env.uniforms()}, width=1024)
    return out.view(np.float32)


def cell_solid_angles(env) -> np.ndarray:
    a, b = _row_weights(env.height)
    return (2.0 * np.pi / env.width) * (a + b)


def alias_probabilities(q: np.ndarray, alias: np.ndarray, n: int) -> np.ndarray:
    """(R, n) probability of each item under alias tables q, alias (R, n'), counted bucket by
    bucket as the shader reads them (a Python loop, independent of mcpt/shading/alias.py)."""
    q, alias = np.atleast_2d(q).astype(np.float64), np.atleast_2d(alias)
    p = np.zeros(q.shape)
    for r in range(q.shape[0]):
        for b in range(q.shape[1]):
            p[r, b] += q[r, b]
            p[r, alias[r, b]] += 1.0 - q[r, b]
    assert (p[:, n:] == 0).all(), "a padding bucket is reachable"
    return p[:, :n] / q.shape[1]


def cell_probabilities(env) -> np.ndarray:
    """(H - 1, W) probability of each cell, from the float32 alias tables the shader reads."""
    pr = alias_probabilities(env.row_q, env.row_alias, env.height - 1)[0]
    pc = alias_probabilities(env.col_q, env.col_alias, env.width)
    return pr[:, None] * pc


def quadrant_probabilities(env) -> np.ndarray:
    """(H - 1, W, 4) probability of each cell's quadrants (fx >= 1/2) + 2 (fz >= 1/2) in
    (u, cos theta): the sampler is bilinear in both with the corners' luminances, and a bilinear
    function integrates over a rectangle to its value at the centre times the area (a black
    cell: a quarter each). Corner luminances computed here, in float64."""
    lum = env.texels.astype(np.float64) @ LUMINANCE
    right = np.roll(lum, -1, axis=1)
    v = np.stack([lum[:-1], right[:-1], lum[1:], right[1:]], -1)            # (hc, W, 4)
    total = v.sum(-1, keepdims=True)
    out = []
    for qz in (0.25, 0.75):
        for qx in (0.25, 0.75):
            b = (1 - qx) * (1 - qz) * v[..., 0] + qx * (1 - qz) * v[..., 1] + (1 - qx) * qz * v[..., 2] \
                + qx * qz * v[..., 3]
            out.append(np.where(total[..., 0] > 0, b / np.where(total[..., 0] > 0, total[..., 0], 1), 0.25))
    return cell_probabilities(env)[..., None] * np.stack(out, -1)


def sub_cells(env, dirs: np.ndarray):
    """Cell (j, i) of each direction and its quadrant in (u, cos theta) within the cell
    (:func:`quadrant_probabilities` says what each expects)."""
    i, _, j, fx, _ = env._cells(dirs)
    cos_t = (np.asarray(dirs, np.float64) @ env.to_world)[:, 1]
    t = np.pi * np.arange(env.height) / (env.height - 1)
    z0, z1 = np.cos(t[j]), np.cos(t[j + 1])
    fz = (z0 - cos_t) / (z0 - z1)
    return j, i, (fx >= 0.5).astype(np.int64) + 2 * (fz >= 0.5)


@pytest.fixture(scope="module")
def maps():
    return {name: build_envmap(make(), to_world=ROT) for name, make in MAPS.items()}


@pytest.mark.parametrize("name", list(MAPS))
def test_glsl_sampling_matches_its_pdf(gl, maps, name):
    env = maps[name]
    u = uniform_numbers(N, 2, seed=len(name))
    out = probe(gl, env, 0, u).astype(np.float64)
    dirs, pdf = out[:, :3], out[:, 3]
    assert np.isfinite(out).all() and (pdf > 0).all()
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=1), 1.0, atol=1e-5)
    prob = cell_probabilities(env)
    j, i, q = sub_cells(env, dirs)
    fine = np.bincount((j * env.width + i) * 4 + q, minlength=prob.size * 4)
    p_fine, stat, dof = chi2_test(fine, quadrant_probabilities(env).ravel() * N)
    assert p_fine > ALPHA, f"{name} sub-cells: chi2 = {stat:.1f} for {dof} dof, p = {p_fine:.3g}"
    # Coarse 8 x 8-cell blocks: the dim parts, pooled away above, tested on their own.
    hc, w = prob.shape
    block = (j // 8) * ((w + 7) // 8) + i // 8
    nb = ((hc + 7) // 8) * ((w + 7) // 8)
    jj, ii = np.mgrid[0:hc, 0:w]
    exp_b = np.bincount(((jj // 8) * ((w + 7) // 8) + ii // 8).ravel(), prob.ravel(), minlength=nb)
    p_coarse, stat, dof = chi2_test(np.bincount(block, minlength=nb), exp_b * N)
    assert p_coarse > ALPHA, f"{name} blocks: chi2 = {stat:.1f} for {dof} dof, p = {p_coarse:.3g}"
    print(f"{name}: p = {p_fine:.3f} (sub-cells), {p_coarse:.3f} (blocks); alpha {ALPHA:.4f}")


def pdf_close(env, dirs, got, want, rtol: float) -> np.ndarray:
    """Whether pdfs agree to ``rtol`` plus 2e-4 of the pdf's largest change across the cell: the
    bilinear factor magnifies a float32 error in the direction (llvmpipe's sin / cos) where a
    cell's corners differ by orders of magnitude (the sun's, 1e-6 to 1)."""
    i, i1, j, _, _ = env._cells(dirs)
    total = env._corners(i, i1, j).sum(axis=1)
    slope = env.cell_pdf[j, i] * 4.0 / np.where(total > 0, total, 4.0)  # a black cell: uniform
    return np.abs(got - want) <= rtol * want + 2e-4 * slope


def test_glsl_warp_is_bilinear_within_cells(gl):
    """The real GLSL sampler inside cells whose corners differ by up to 10^3 (a 6 x 4 map, random
    luminances, one black corner region): 8 x 8 sub-cells in (fx, fz) against the bilinear
    density, whose integral over a sub-cell is its value at the centre times the area."""
    rng = np.random.default_rng(11)
    img = (10.0 ** rng.uniform(-3.0, 0.0, (4, 6, 1)) * np.array([1.0, 0.8, 0.6])).astype(np.float32)
    img[2, 4:] = 0.0
    env = build_envmap(img, to_world=ROT)
    out = probe(gl, env, 0, uniform_numbers(N, 2, seed=21)).astype(np.float64)
    assert np.isfinite(out).all() and (out[:, 3] > 0).all()
    i, _, j, fx, fy = env._cells(out[:, :3])
    fz = np.clip(_cos_fraction(j, env.height - 1, fy), 0.0, 1.0 - 1e-12)
    k = 8
    hist = np.bincount(((j * env.width + i) * k + (fz * k).astype(int)) * k + (fx * k).astype(int),
                       minlength=(env.height - 1) * env.width * k * k)
    c = (np.arange(k) + 0.5) / k
    lum = env.texels.astype(np.float64) @ LUMINANCE
    right = np.roll(lum, -1, axis=1)
    v00, v10, v01, v11 = (x[..., None, None] for x in (lum[:-1], right[:-1], lum[1:], right[1:]))
    z, x = c[:, None], c[None, :]
    b = (1 - x) * (1 - z) * v00 + x * (1 - z) * v10 + (1 - x) * z * v01 + x * z * v11   # (hc, W, k, k)
    total = (v00 + v10 + v01 + v11)
    share = np.where(total > 0, b / np.where(total > 0, total, 1.0) * 4.0, 1.0) / (k * k)
    expected = cell_probabilities(env)[..., None, None] * share
    p_val, stat, dof = chi2_test(hist, expected.ravel() * N)
    print(f"bilinear sub-cells: p = {p_val:.3f}, {dof} dof")
    assert p_val > ALPHA, f"bilinear sub-cells: chi2 = {stat:.1f} for {dof} dof, p = {p_val:.3g}"


@pytest.mark.parametrize("name", list(MAPS))
def test_glsl_agrees_with_numpy_and_its_own_pdf(gl, maps, name):
    env = maps[name]
    u = uniform_numbers(1 << 16, 2, seed=100 + len(name))
    out = probe(gl, env, 0, u).astype(np.float64)
    dirs, pdf = env.sample(u)
    np.testing.assert_allclose(out[:, :3], dirs, atol=2e-5)
    # The same cell but for directions within float rounding of a cell border.
    i, _, j, fx, fy = env._cells(dirs)
    edge = (np.minimum(fx, 1 - fx) < 1e-4) | (np.minimum(fy, 1 - fy) < 1e-4)
    assert (pdf_close(env, dirs, out[:, 3], pdf, 1e-4) | edge).all() and edge.sum() <= 1e-3 * len(u)
    # env_pdf and env_radiance of the sampled direction: what the sample returned.
    back = probe(gl, env, 2, out[:, :3].astype(np.float32)).astype(np.float64)
    np.testing.assert_allclose(back[:, 3], out[:, 3], rtol=1e-4)
    le = probe(gl, env, 1, u).astype(np.float64)
    np.testing.assert_allclose(le[:, 3], out[:, 3], rtol=1e-4)
    np.testing.assert_allclose(le[:, :3], back[:, :3], rtol=1e-4, atol=1e-6)
    # Radiance and pdf at arbitrary directions: the numpy reference (bilinear, exact texels).
    v = np.random.default_rng(7).standard_normal((1 << 15, 3))
    v = (v / np.linalg.norm(v, axis=1, keepdims=True)).astype(np.float32).astype(np.float64)
    ev = probe(gl, env, 2, v.astype(np.float32)).astype(np.float64)
    ref = env.eval(v)
    i, i1, j, fx, fy = env._cells(v)
    edge = (np.minimum(fx, 1 - fx) < 1e-4) | (np.minimum(fy, 1 - fy) < 1e-4)
    assert edge.sum() < 0.01 * len(v)
    # Bilinear weights carry float32 rounding (~1e-6 of a texel): scale by the cell's brightest
    # corner; on a cell border the GLSL may take the neighbouring cell (the same value there).
    corner = np.max([env.texels[j, i], env.texels[j, i1], env.texels[j + 1, i], env.texels[j + 1, i1]], axis=0)
    assert ((np.abs(ev[:, :3] - ref) <= 1e-4 * corner + 1e-6).all(axis=1) | edge).all()
    assert (pdf_close(env, v, ev[:, 3], env.pdf(v), 1e-6) | edge).all()


@pytest.mark.parametrize("name", list(MAPS))
def test_glsl_pdf_integrates_to_one_poles_included(gl, maps, name):
    """Quadrature of the GLSL env_pdf: 4 x 4 midpoints of every cell in (u, cos theta), the rows
    of cells at the poles included (exact for a per-cell constant); and the pdf at the poles."""
    env = maps[name]
    w, hc, k = env.width, env.height - 1, 4
    t = np.pi * np.arange(env.height) / hc
    fr = (np.arange(k) + 0.5) / k
    z = np.cos(t[:-1, None]) + (np.cos(t[1:]) - np.cos(t[:-1]))[:, None] * fr     # (hc, k)
    phi = 2.0 * np.pi * (np.arange(w)[:, None] + 0.5 + fr) / w                     # (w, k)
    Z = np.broadcast_to(z[:, None, :, None], (hc, w, k, k))
    P = np.broadcast_to(phi[None, :, None, :], (hc, w, k, k))
    s = np.sqrt(1.0 - Z**2)
    local = np.stack([np.sin(P) * s, Z, -np.cos(P) * s], -1).reshape(-1, 3)
    pdf = probe(gl, env, 2, (local @ env.to_world.T).astype(np.float32))[:, 3].astype(np.float64)
    omega = np.repeat(cell_solid_angles(env), w * k * k) / (k * k)
    total = float(pdf @ omega)
    assert abs(total - 1.0) < 1e-4, f"the pdf integrates to {total:.6f}"
    rows = (pdf * omega).reshape(hc, -1).sum(axis=1)
    np.testing.assert_allclose(rows[[0, -1]], cell_probabilities(env).sum(axis=1)[[0, -1]], rtol=1e-4)
    poles = (np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]) @ env.to_world.T).astype(np.float32)
    at = probe(gl, env, 2, poles)[:, 3]
    assert np.isfinite(at).all() and (at > 0).all()
    # The cells of a pole row all meet at the pole, where the bilinear factor depends on the cell
    # and fx that the direction's rounding picks: the pdf there is one of the pole edge's values,
    # between the cell's pdf times 4 v_a / sum(v) and 4 v_b / sum(v), v_a, v_b the corners on it.
    for k, row, edge in ((0, 0, (0, 1)), (1, -1, (2, 3))):
        i = np.arange(env.width)
        v = env._corners(i, (i + 1) % env.width, np.full(env.width, np.arange(hc)[row]))
        ends = env.cell_pdf[row][:, None] * 4.0 * v[:, edge] / v.sum(axis=1, keepdims=True)
        assert ends.min() * (1 - 1e-5) <= at[k] <= ends.max() * (1 + 1e-5), (k, at[k], ends.min(), ends.max())


def test_estimator_is_unbiased_and_exact_for_a_constant_map(gl):
    """le / pdf of GLSL samples: 4 pi L exactly for a constant map (the sampler is proportional to
    the radiance); its mean the exact integral of the bilinear radiance for the sun map."""
    const = build_envmap(np.full((1, 1, 3), 0.7, np.float32), scale=(1.0, 2.0, 3.0))
    le = probe(gl, const, 1, uniform_numbers(4096, 2, seed=3)).astype(np.float64)
    np.testing.assert_allclose(le[:, :3] / le[:, 3:], np.broadcast_to(4 * np.pi * 0.7 * np.array([1, 2, 3]),
                                                                      (4096, 3)), rtol=1e-5)
    env = build_envmap(sun_map(), to_world=ROT)
    est = probe(gl, env, 1, uniform_numbers(N, 2, seed=4)).astype(np.float64)
    f = est[:, :3] @ LUMINANCE / est[:, 3]
    want = env.radiance_integral @ LUMINANCE
    assert abs(f.mean() - want) < 5 * f.std() / math.sqrt(N), (f.mean(), want)
    # The exact integral is right: uniform directions (numpy) estimate it too.
    v = np.random.default_rng(5).standard_normal((1 << 20, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    g = env.eval(v) @ LUMINANCE * 4 * np.pi
    assert abs(g.mean() - want) < 5 * g.std() / math.sqrt(len(g))


def mitsuba_direction(u: float, v: float) -> np.ndarray:
    """Mitsuba 3.9.1 src/emitters/envmap.cpp l. 439-446 (uv_to_direction):
    (sin(2 pi u) sin(pi v), cos(pi v), -cos(2 pi u) sin(pi v))."""
    t, p = math.pi * v, 2.0 * math.pi * u
    return np.array([math.sin(p) * math.sin(t), math.cos(t), -math.cos(p) * math.sin(t)])


@pytest.mark.parametrize("x,y", [(5, 4), (0, 1), (31, 14), (16, 7)])
def test_orientation_is_mitsubas(gl, x, y):
    """One bright texel of a 32 x 16 map is seen along Mitsuba's direction of its centre:
    u = (x + 1/2) / W (l. 537-539: texel-centred phi), v = y / (H - 1) (l. 538-540: rows on the
    poles), through to_world; its neighbours' centres see nothing of it."""
    w, h = 32, 16
    img = np.zeros((h, w, 3), np.float32)
    img[y, x] = (5.0, 6.0, 7.0)
    for rot in (np.eye(3), ROT):
        env = build_envmap(img, to_world=rot)
        dirs = [mitsuba_direction((x + 0.5 + dx) / w, (y + dy) / (h - 1)) for dx, dy in
                ((0, 0), (1, 0), (-1, 0), (0, 1), (0, -1))]
        out = probe(gl, env, 2, (np.array(dirs) @ rot.T).astype(np.float32)).astype(np.float64)
        np.testing.assert_allclose(out[0, :3], (5.0, 6.0, 7.0), rtol=1e-4)
        np.testing.assert_allclose(out[1:, :3], 0.0, atol=1e-3)
    # Landmarks: the image's top row is +Y, its left edge (u = 0) looks along -Z, u = 1/4 along +X.
    np.testing.assert_allclose(mitsuba_direction(0.3, 0.0), (0, 1, 0), atol=1e-12)
    np.testing.assert_allclose(mitsuba_direction(0.0, 0.5), (0, 0, -1), atol=1e-12)
    np.testing.assert_allclose(mitsuba_direction(0.25, 0.5), (1, 0, 0), atol=1e-12)


def test_tiny_images_pad_like_mitsuba():
    env = build_envmap(np.full((1, 1, 3), 2.0, np.float32))
    assert (env.width, env.height) == (2, 3)
    np.testing.assert_allclose(env.cell_pdf, 1.0 / (4.0 * np.pi), rtol=1e-6)
    np.testing.assert_allclose(env.radiance_integral, 8.0 * np.pi, rtol=1e-12)
    assert env.mean_radiance_luminance == pytest.approx(2.0)
    assert env.power(3.0) == pytest.approx(math.pi * 9.0 * 8.0 * math.pi)  # pi r^2 x 4 pi L
    two = build_envmap(np.array([[[1, 1, 1]], [[3, 3, 3]]], np.float32))  # 1 x 2: last row repeated
    np.testing.assert_array_equal(two.texels[:, :, 0], [[1, 1], [3, 3], [3, 3]])
    black = build_envmap(np.zeros((4, 8, 3), np.float32))  # samples uniformly, radiance 0
    np.testing.assert_allclose(black.cell_pdf, 1.0 / (4.0 * np.pi), rtol=1e-5)


# ------------------------------------------------------------------------------------------------
# files


def write_exr(path, rgb):
    import OpenEXR

    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {"RGB": np.ascontiguousarray(rgb, np.float32)}).write(str(path))


def test_reads_exr_hdr_and_ldr(tmp_path, caplog):
    import cv2

    rgb = np.random.default_rng(1).random((6, 10, 3)).astype(np.float32) * 50
    write_exr(tmp_path / "a.exr", rgb)
    np.testing.assert_array_equal(read_envmap(tmp_path / "a.exr"), rgb)
    env = load_envmap(tmp_path / "a.exr", scale=(1.0, 0.5, 2.0))
    np.testing.assert_allclose(env.texels, rgb * np.float32([1.0, 0.5, 2.0]), rtol=1e-7)
    cv2.imwrite(str(tmp_path / "a.hdr"), rgb[:, :, ::-1])
    img, note = read_envmap_image(tmp_path / "a.hdr")
    # RGBE: 8-bit mantissas under the pixel's largest channel's exponent.
    assert (np.abs(img - rgb) <= 2 ** -7 * rgb.max(axis=2, keepdims=True)).all()
    assert note is None
    px = np.zeros((2, 3, 3), np.uint8)
    px[0, 0] = (255, 0, 0)   # red, in RGB
    px[1, 2] = (0, 0, 188)
    cv2.imwrite(str(tmp_path / "a.png"), px[:, :, ::-1])
    with caplog.at_level("WARNING", logger="mcpt"):
        img = read_envmap(tmp_path / "a.png")
    np.testing.assert_allclose(img[0, 0], (1, 0, 0))
    np.testing.assert_allclose(img[1, 2, 2], ((188 / 255 + 0.055) / 1.055) ** 2.4, rtol=1e-6)
    assert [r.getMessage() for r in caplog.records] == [f"{tmp_path / 'a.png'}: {LDR_NOTE}"]


def _patched_exr(path, width=100000, height=50000):
    """A valid 4 x 2 EXR whose header then claims ``width`` x ``height`` pixels."""
    write_exr(path, np.ones((2, 4, 3), np.float32))
    b = bytearray(path.read_bytes())
    k = b.find(b"dataWindow\x00box2i\x00") + len(b"dataWindow\x00box2i\x00") + 4
    b[k:k + 16] = struct.pack("<4i", 0, 0, width - 1, height - 1)
    path.write_bytes(bytes(b))


def _bad_files(tmp):
    (tmp / "text.exr").write_text("not an image\n")
    (tmp / "text.hdr").write_text("hello\n")
    nan = np.ones((4, 8, 3), np.float32)
    nan[1, 2, 0] = np.nan
    nan[3, 3] = np.inf
    write_exr(tmp / "nan.exr", nan)
    neg = np.ones((4, 8, 3), np.float32)
    neg[0, 0, 1] = -1e-3
    write_exr(tmp / "negative.exr", neg)
    _patched_exr(tmp / "huge.exr")
    (tmp / "huge.hdr").write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 50000 +X 100000\n")
    return {"text.exr": "not an OpenEXR image", "text.hdr": "not a Radiance .hdr",
            "nan.exr": "2 NaN or infinite texels", "negative.exr": "1 negative texels",
            "huge.exr": "100000 x 50000", "huge.hdr": "100000 x 50000", "missing.exr": "not found"}


def test_bad_files_are_one_line_errors_naming_the_file(tmp_path):
    for name, words in _bad_files(tmp_path).items():
        with pytest.raises(EnvMapError) as exc:
            read_envmap(tmp_path / name)
        msg = str(exc.value)
        assert "\n" not in msg and msg.startswith(str(tmp_path / name)) and words in msg, msg
    assert str(MAX_ENV_TEXELS) in str(pytest.raises(EnvMapError, read_envmap, tmp_path / "huge.exr").value)


def test_bad_arguments_are_refused():
    img = np.ones((4, 8, 3), np.float32)
    for kwargs, words in (({"scale": -1.0}, "scale"), ({"scale": (1, 2)}, "scale"),
                          ({"to_world": np.diag([1.0, 2.0, 1.0])}, "rotation"),
                          ({"to_world": np.zeros((3, 3))}, "singular")):
        with pytest.raises(EnvMapError, match=words):
            build_envmap(img, name="scene.xml: emitter envmap", **kwargs)
    with pytest.raises(EnvMapError, match="1 negative"):
        build_envmap(-img[:1, :1], name="x")
    mirror = build_envmap(img, to_world=2.0 * np.diag([-1.0, 1.0, 1.0]))  # a mirror, scaled: fine
    np.testing.assert_allclose(mirror.to_world, np.diag([-1.0, 1.0, 1.0]))


def test_the_reader_itself_preflights_memory_from_the_header(tmp_path, monkeypatch):
    """read_envmap / load_envmap (the Python API, the Mitsuba XML reader) refuse a map that the
    memory cannot hold before decoding it: the .exr header claims 4096 x 2048, its pixels are 4 x 2."""
    from mcpt.gpu import host_memory
    from mcpt.shading.envmap_file import ENV_BYTES_PER_TEXEL

    _patched_exr(tmp_path / "m.exr", 4096, 2048)
    monkeypatch.setattr(host_memory, "available_bytes", lambda: 4096 * 2048 * ENV_BYTES_PER_TEXEL - 1)
    with pytest.raises(EnvMapError, match=r"m\.exr: 4096 x 2048 needs about 0\.6 GiB to load, more than the "
                                          r"0\.6 GiB of memory available"):
        load_envmap(tmp_path / "m.exr")

"""Equiangular sampling in media (issue #25, glsl/medium_equiangular.glsl): its distances against
their closed-form density (chi-square on the real GLSL), its estimate against free flight's, and
single scattering of a point light against the integral it estimates."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mcpt.gpu.features import for_world, loop_limit_for
from mcpt.scene import parse_scene
from mcpt.shading.camera import basis
from mcpt.shapes.world import load_world

from .conftest import ROOT
from .draw import render as draw
from .test_materials_util import chi2_test, renderer, uniform_numbers
from .test_medium import ALPHA, _render, probe


@pytest.mark.parametrize("t_max", [3.0, 40.0])
def test_equiangular_sampling_matches_its_pdf(gl, t_max):
    """Equiangular distances (Kulla & Fajardo 2012) along a segment of length t_max passing a light
    0.3 from the line at t = 1.2, binned, against the closed form D / ((theta_b - theta_a)
    (D^2 + (t - delta)^2)) integrated over each bin; the returned q is that density."""
    d = np.array([0.6, 0.0, 0.8])
    c = 1.2 * d + np.array([0.0, 0.3, 0.0])
    n = 1 << 19
    items = np.stack([uniform_numbers(n, 1, 5)[:, 0], np.full(n, t_max, np.float32)], axis=1)
    out = probe(gl, 3, items, u_d=tuple(d), u_c=tuple(map(float, c))).astype(np.float64)
    t, q = out[:, 0], out[:, 1]
    assert t.min() >= -1e-5 and t.max() <= t_max * (1 + 1e-5)
    ta, tb = math.atan(-1.2 / 0.3), math.atan((t_max - 1.2) / 0.3)
    pdf = lambda x: 0.3 / ((tb - ta) * (0.09 + (x - 1.2) ** 2))  # noqa: E731
    assert np.allclose(q, pdf(t), rtol=1e-3)
    edges = np.linspace(0.0, t_max, 201)
    cdf = (np.arctan((edges - 1.2) / 0.3) - ta) / (tb - ta)
    p, stat, dof = chi2_test(np.histogram(t, edges)[0], np.diff(cdf) * n)
    assert p > ALPHA, f"t_max {t_max}: chi2 = {stat:.1f} for {dof} dof, p = {p:.3g}"


def test_equiangular_and_free_flight_agree_on_a_lamp_in_fog(gl):
    """A point light in fog over a floor: the image with equiangular sampling (MIS with free-flight
    vertices) and without it have the same mean, within their noise."""
    text = """
camera: {position: [0, 1, 4], look_at: [0, 0, 0], vfov_deg: 40, resolution: [24, 24]}
render: {bounces: 4}
materials:
  floor: {albedo: [0.5, 0.5, 0.5]}
meshes:
  - {shape: rectangle, material: floor, transform: {scale: 3, rotate_deg: [-90, 0, 0], translate: [0, -1, 0]}}
lights:
  - {type: point, position: [0.3, 0.2, 0.5], intensity: [2, 2, 2]}
medium: {albedo: [0.9, 0.8, 0.7], density: 0.3, g: 0.4}
"""
    world = load_world(parse_scene(text, ROOT / "scenes" / "inline.yaml"))
    base = for_world(world, variance=True, loop_limit=loop_limit_for(gl.renderer))
    means, errors = [], []
    for eq in (True, False):
        f = base.replace(equiangular=eq)
        assert f.defines()["MCPT_MEDIUM_EQUIANGULAR"] == int(eq)
        r = renderer(gl, world, f)
        try:
            res = draw(r, 256, 8)
        finally:
            r.release()
        means.append(res.image.reshape(-1, 3).mean(0))
        errors.append(np.sqrt(res.variance.reshape(-1, 3).mean(0) / res.image[..., 0].size))
    assert np.all(np.abs(means[0] - means[1]) < 4 * np.hypot(*errors)), (means, errors)


def single_scattering(o, d, c, intensity, sigma_s, sigma_t, g, n=4000):
    """Radiance scattered once towards o along -d by a homogeneous medium filling space, lit by a
    point light of intensity I at c: the integral over t of sigma_s Tr(t) p(theta) I Tr(r) / r^2,
    taken in the equiangular angle (t = delta + D tan(theta), dt / r^2 = dtheta / D) where the
    integrand is smooth (midpoint rule)."""
    delta = float(np.dot(c - o, d))
    D = float(np.linalg.norm(c - o - delta * d))
    ta = math.atan(-delta / D)
    th = ta + (np.arange(n) + 0.5) * (math.pi / 2 - ta) / n
    t, r = delta + D * np.tan(th), D / np.cos(th)
    cos = (delta - t) / r  # between d and the direction from x to the light
    phase = (1 - g * g) / (4 * math.pi * (1 + g * g - 2 * g * cos) ** 1.5)
    return sigma_s * intensity / D * (np.exp(-sigma_t * (t + r)) * phase).sum() * (math.pi / 2 - ta) / n


def test_single_scattering_of_a_point_light_matches_its_integral(gl):
    """bounces 1: a point light in fog that fills space, nothing else in view; each pixel is the
    single scattering along its camera rays (box filter: 4 x 4 rays a pixel, 24 x 24 in the
    light's), integrated above."""
    text = """
camera: {position: [0, 0, 4], look_at: [0, 0, 0], vfov_deg: 30, resolution: [12, 12]}
render: {bounces: 1}
materials:
  black: {albedo: [0, 0, 0]}
meshes:
  - {shape: rectangle, material: black, transform: {scale: 0.01, translate: [0, 0, 9]}}
lights:
  - {type: point, position: [0.3, 0.2, 0.5], intensity: [1, 2, 3]}
medium: {sigma_a: 0.05, sigma_s: 0.2, g: 0.3}
"""
    sc = parse_scene(text, ROOT / "scenes" / "inline.yaml")
    res, feats = _render(gl, text, 256, 12)
    assert feats.defines()["MCPT_MEDIUM_EQUIANGULAR"] == 1
    cam = sc.camera
    f, r, u = basis(cam.position, cam.look_at, cam.up, cam.vfov_deg, cam.width, cam.height)
    o, c = np.asarray(cam.position, float), np.array([0.3, 0.2, 0.5])
    expected = np.zeros((12, 12))
    for row in range(12):
        for col in range(12):
            m = 24 if (row, col) == (4, 7) else 4  # the light's pixel: the integrand peaks (1 / D)
            sub = (np.arange(m) + 0.5) / m
            vals = []
            for a in sub:
                for b in sub:
                    sx, sy = 2 * (col + a) / 12 - 1, 1 - 2 * (row + b) / 12
                    d = f + sx * r + sy * u
                    vals.append(single_scattering(o, d / np.linalg.norm(d), c, 1.0, 0.2, 0.25, 0.3))
            expected[row, col] = np.mean(vals)
    got = res.image / np.array([1.0, 2.0, 3.0])  # the intensity's channels scale it
    ratio = got[..., 0] / expected
    se = np.sqrt(res.variance[..., 0])  # each pixel's standard error (red: intensity 1)
    assert np.all(np.abs(got[..., 0] - expected) < 4 * se + 0.005 * expected), ratio.round(3)
    assert abs(got.mean() / expected.mean() - 1) < 0.01, got.mean() / expected.mean()

"""Environment maps (Mitsuba's ``envmap`` emitter): radiance arriving from infinitely far away,
from a latitude-longitude image, with the tables that importance-sample it for next-event
estimation (GLSL side: glsl/envmap.glsl; reading files: mcpt/shading/envmap_file.py).

**Mapping: exactly Mitsuba 3's** (src/emitters/envmap.cpp at v3.9.1, 478e193a1). In the emitter's
frame a direction d and texture coordinates (u, v) in [0, 1]^2 are related by

    d = (sin(2 pi u) sin(pi v), cos(pi v), -cos(2 pi u) sin(pi v))    (uv_to_direction, l. 439-446)
    u = atan2(d.x, -d.z) / (2 pi),  v = acos(d.y) / pi                (direction_to_uv, l. 449-452)

so +Y is up (v = 0, the image's top row), u = 0 looks along -Z, u = 1/4 along +X, u = 1/2 along +Z.
The radiance is Mitsuba's bilinear lookup (eval_spectrum, l. 533-540): column x is centred on
u = (x + 1/2) / W, periodic in u; row y lies on v = y / (H - 1), so the top and bottom rows sit
on the poles ("align corners" in theta). World directions map through ``to_world`` (a rotation,
or a mirror: its transpose is its inverse): d_local = to_world^T d_world (eval, l. 278).
An image smaller than 2 x 3 is first padded to it by repeating its last column and row, as
Mitsuba's ``Bitmap::pad_to`` does (l. 137), so a 1 x 1 image is a constant environment.

**Sampling.** The cells between four neighbouring texels ((W) x (H - 1) of them, cell (i, j)
spanning u in [(i + 1/2), (i + 3/2)] / W and v in [j, j + 1] / (H - 1)) get a piecewise-constant
distribution (pbrt-v4 sec. A.5 "Piecewise-constant 2D distributions": a marginal distribution
over the rows of cells, a conditional one over the cells of each row, each drawn from an alias
table, mcpt/shading/alias.py: O(1), two table reads per sample where two binary searches cost
~log2(H) + log2(W) dependent reads and loop trips under llvmpipe's 8-lane masks) proportional to
the integral of the luminance over each cell's solid angle, that is luminance x sin(theta) integrated exactly (the
bilinear function is linear in theta along a column: weights :func:`_row_weights`). Inside the
chosen cell the direction is *bilinear* in (fx, fz), fx the fraction in phi and fz in cos theta,
with the luminances of the cell's four corners (pbrt-v4's SampleBilinear, sec. A.5; uniform in a
black cell). (phi, cos theta) is uniform in solid angle (pbrt-v4 sec. 12.5: pdf_uv = pdf_sa 2 pi^2
sin theta, Mitsuba l. 352-356), so the solid-angle pdf is ``P(cell) / solid_angle(cell)`` (stored
per cell) times the bilinear factor B(fx, fz) / mean(corners): finite and consistent at the
poles, no division by sin theta anywhere.

Mitsuba samples the same luminance x sin(theta) with a bilinear density in (u, v) (Hierarchical2D);
ours is bilinear in (phi, cos theta) and the radiance bilinear in (phi, theta), a small difference
in a band of pi / (H - 1); the per-cell constant density this replaced had 1.55x Mitsuba's relMSE
at 64 spp on bench/scenes-xml/lights-envmap-diffuse.xml, the bilinear one 0.71x (issue #20;
``python -m mcpt.bench.envmap_peer``). The estimator stays unbiased because the pdf is positive
wherever the radiance is (a cell's probability is positive when a corner is, and the bilinear
factor vanishes only where corners of zero luminance, hence zero radiance, meet), and env_pdf
returns the density env_sample actually uses. P(cell) is computed from the float32
alias tables the shader reads (alias.realised), so a cell that float32 rounding makes unreachable
has pdf 0 (BSDF sampling then finds it alone, with MIS weight 1) instead of a pdf no sample
realises.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .alias import build_alias, realised
from .envmap_file import (
    MAX_ENV_TEXELS,
    MIN_HEIGHT,
    MIN_WIDTH,
    EnvMapError,
    check_texels,
    read_envmap,
    read_envmap_image,
)

__all__ = ["MAX_ENV_TEXELS", "EnvMap", "EnvMapError", "build_envmap", "load_envmap", "read_envmap",
           "read_envmap_image"]

#: Rec. 709 luminance weights (the same as mcpt/shading/lights.py LUMINANCE and glsl/common.glsl).
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])

#: The GLSL twin, included by glsl/lights.glsl under MCPT_ENVMAP (also what tells the wheel check
#: of tests/test_package.py that it is renderer code, not a probe, before that include exists).
GLSL_FILE = "envmap.glsl"

@dataclass(frozen=True, eq=False)
class EnvMap:
    """An environment map and its sampling tables. ``texels`` include the scale and the padding.

    GPU layout (:meth:`pack`; names are mcpt/gpu/tbo.py UNITS, units 10 and 11):

    * ``env_texels``: W x H RGBA32UI texels, texel ``y W + x`` = (R, G, B, p) as float bits, the
      image row by row from the top (v = 0, +Y); p = solid-angle pdf of cell (x, y) (rows
      0 .. H - 2; 0 in the last row, which starts no cell).
    * ``env_alias``: alias-table entries (threshold q as float bits, alias index), two per
      RGBA32UI texel (entry e in texel e >> 1, components xy if e is even, zw if odd): entries
      [0, H') the table over the rows of cells, H' = padded_size(H - 1); then at H' + j W' + i
      entry i of row j's table over its cells, W' = padded_size(W) (alias.py: powers of two).

    Uniforms (:meth:`uniforms`): ``u_env_size`` = (W, H), ``u_env_to_world`` (mat3).
    """

    texels: np.ndarray           # (H, W, 3) float32 radiance (scaled, padded to >= 2 x 3)
    to_world: np.ndarray         # (3, 3) float64, orthogonal
    row_q: np.ndarray            # (H',) float32 alias thresholds over the rows of cells
    row_alias: np.ndarray        # (H',) int32 row aliases
    col_q: np.ndarray            # (H - 1, W') float32 alias thresholds over each row's cells
    col_alias: np.ndarray        # (H - 1, W') int32 cell aliases
    cell_pdf: np.ndarray         # (H - 1, W) float32 solid-angle pdf (1/sr) of each cell
    radiance_integral: np.ndarray  # (3,) float64: integral of the radiance over the sphere (x sr)

    @property
    def width(self) -> int:
        return int(self.texels.shape[1])

    @property
    def height(self) -> int:
        return int(self.texels.shape[0])

    @property
    def mean_radiance_luminance(self) -> float:
        """Luminance of the radiance averaged over the sphere (the constant environment of the
        same irradiance on every side); a light-selection weight for the lights helper
        (pbrt-v4's infinite-light power is pi r^2 times 4 pi times this, r the scene's radius)."""
        return float(self.radiance_integral @ LUMINANCE / (4.0 * np.pi))

    def power(self, radius: float) -> float:
        """pbrt-v4's power of an infinite light seen by a scene of bounding radius ``radius``:
        pi r^2 times the luminance integral over the sphere (the flux through a disk of radius r)."""
        return float(np.pi * radius**2 * (self.radiance_integral @ LUMINANCE))

    # --- GPU ------------------------------------------------------------------------------------

    def pack(self) -> dict[str, np.ndarray]:
        """The two buffer textures by name (layout in the class docstring)."""
        h, w = self.height, self.width
        tex = np.zeros((h * w, 4), np.float32)
        tex[:, :3] = self.texels.reshape(-1, 3)
        tex[: (h - 1) * w, 3] = self.cell_pdf.ravel()
        q = np.concatenate([self.row_q, self.col_q.ravel()]).astype(np.float32)
        a = np.concatenate([self.row_alias, self.col_alias.ravel()]).astype(np.uint32)
        ent = np.zeros((q.size + q.size % 2, 2), np.uint32)
        ent[: q.size, 0], ent[: q.size, 1] = q.view(np.uint32), a
        return {"env_texels": tex.view(np.uint32), "env_alias": ent.reshape(-1, 4)}

    def uniforms(self) -> dict[str, tuple]:
        """The uniforms of glsl/envmap.glsl (mat3 column-major, as moderngl takes it)."""
        return {"u_env_size": (self.width, self.height),
                "u_env_to_world": tuple(float(x) for x in self.to_world.T.ravel())}

    # --- numpy reference (float64), the same steps as glsl/envmap.glsl ----------------------------

    def _cells(self, dirs: np.ndarray):
        """Cell (i, j) of world directions, the column right of i (periodic), bilinear weights."""
        d = np.asarray(dirs, np.float64) @ self.to_world  # rows: to_world^T d
        w, h = self.width, self.height
        r = np.hypot(d[:, 0], d[:, 2])
        phi = np.where(r > 0.0, np.arctan2(d[:, 0], -d[:, 2]), 0.0)
        theta = np.arctan2(r, d[:, 1])
        x = phi * (w / (2.0 * np.pi)) - 0.5      # u W - 1/2, u = phi / 2 pi
        x = np.where(x < 0.0, x + w, x)
        i = np.floor(x)
        fx = x - i
        i = i.astype(np.int64)
        i = np.where(i >= w, i - w, i)
        y = theta * ((h - 1) / np.pi)            # v (H - 1)
        j = np.minimum(np.floor(y), h - 2).astype(np.int64)
        return i, np.where(i + 1 >= w, 0, i + 1), j, fx, y - j

    def eval(self, dirs: np.ndarray) -> np.ndarray:
        """(N, 3) radiance seen along world directions ``dirs`` (N, 3), unit."""
        i, i1, j, fx, fy = self._cells(dirs)
        t = self.texels.astype(np.float64)
        fx, fy = fx[:, None], fy[:, None]
        top = t[j, i] * (1 - fx) + t[j, i1] * fx
        bottom = t[j + 1, i] * (1 - fx) + t[j + 1, i1] * fx
        return top * (1 - fy) + bottom * fy

    def _corners(self, i, i1, j) -> np.ndarray:
        """(N, 4) luminances of cells' corners (v00, v10, v01, v11), divided by the largest
        (glsl/envmap.glsl env_corner_lum)."""
        t = self.texels
        v = np.stack([t[j, i], t[j, i1], t[j + 1, i], t[j + 1, i1]], axis=1).astype(np.float64) @ LUMINANCE
        m = v.max(axis=1, keepdims=True)
        return v / np.where(m > 0.0, m, 1.0)

    def pdf(self, dirs: np.ndarray) -> np.ndarray:
        """(N,) solid-angle density (1/sr) of :meth:`sample` at world directions ``dirs``."""
        i, i1, j, fx, fy = self._cells(dirs)
        fz = _cos_fraction(j, self.height - 1, fy)
        return self.cell_pdf[j, i].astype(np.float64) * _bilinear_pdf(fx, fz, self._corners(i, i1, j))

    def sample(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World directions (N, 3) and their pdfs (N,) for uniform numbers ``u`` (N, 2) in
        [0, 1): u[:, 1] picks the row of cells, u[:, 0] the cell in it (float32 alias tables, as
        the shader), the remainders place the direction in the cell."""
        u = np.asarray(u, np.float32)
        w, hc = self.width, self.height - 1
        j, tv = _alias_pick(u[:, 1], self.row_q, self.row_alias)
        i, tu = _alias_pick(u[:, 0], self.col_q[j], self.col_alias[j])
        v = self._corners(i, np.where(i + 1 >= w, 0, i + 1), j)
        fz = _sample_linear(tv, v[:, 0] + v[:, 1], v[:, 2] + v[:, 3])
        fx = _sample_linear(tu, v[:, 0] + (v[:, 2] - v[:, 0]) * fz, v[:, 1] + (v[:, 3] - v[:, 1]) * fz)
        phi = (i + 0.5 + fx) * (2.0 * np.pi / w)
        cos_t, sin_t = _band_point(j, hc, fz)
        local = np.stack([np.sin(phi) * sin_t, cos_t, -np.cos(phi) * sin_t], axis=1)
        dirs = local @ self.to_world.T
        return dirs, self.pdf(dirs)


def _alias_pick(u: np.ndarray, q: np.ndarray, alias: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Items and remainders in [0, 1) for float32 numbers u under alias tables (one per u if 2-D),
    in float32 as glsl/envmap.glsl env_alias_pick: bucket b = floor(u n), fraction f = u n - b
    (exact: n is a power of two), b itself if f < q_b, else its alias."""
    n = q.shape[-1]
    x = u * np.float32(n)
    b = x.astype(np.int64)
    f = x - b.astype(np.float32)
    rows = np.arange(len(u))
    qb = q[b] if q.ndim == 1 else q[rows, b]
    ab = alias[b] if alias.ndim == 1 else alias[rows, b]
    own = f < qb
    t = np.where(own, f / np.where(own, qb, 1.0), (f - qb) / np.where(own, 1.0, 1.0 - qb))
    return np.where(own, b, ab), np.clip(t.astype(np.float64), 0.0, 1.0)


def _sample_linear(u: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """pbrt-v4 SampleLinear (glsl/envmap.glsl env_sample_linear): x in [0, 1) with density
    proportional to (1 - x) a + x b, a, b >= 0; uniform where a == b."""
    den = a + np.sqrt(a * a + (b * b - a * a) * u)
    x = np.where(den > 0.0, u * (a + b) / np.where(den > 0.0, den, 1.0), 0.0)
    return np.where(a == b, u, np.minimum(x, np.nextafter(1.0, 0.0)))


def _bilinear_pdf(fx: np.ndarray, fz: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The bilinear warp's density at (fx, fz) relative to uniform: B / mean of the corners v
    (N, 4); 1 for a black cell (glsl/envmap.glsl env_bilinear_pdf)."""
    s = v.sum(axis=1)
    top = v[:, 0] + (v[:, 1] - v[:, 0]) * fx
    bottom = v[:, 2] + (v[:, 3] - v[:, 2]) * fx
    return np.where(s > 0.0, 4.0 * (top + (bottom - top) * fz) / np.where(s > 0.0, s, 1.0), 1.0)


def _cos_fraction(j: np.ndarray, hc: int, fy: np.ndarray) -> np.ndarray:
    """Fraction in cos theta across row j's band of the direction at fraction fy in theta, by
    cos a - cos b = 2 sin((a + b) / 2) sin((b - a) / 2) (glsl/envmap.glsl env_cos_fraction)."""
    dt = np.pi / hc
    tj = j * dt
    return np.sin(tj + 0.5 * fy * dt) * np.sin(0.5 * fy * dt) / (np.sin(tj + 0.5 * dt) * np.sin(0.5 * dt))


def _band_point(j: np.ndarray, hc: int, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(cos theta, sin theta) at fraction t of row j's band, uniform in cos theta. Written with
    s = 1 -+ cos theta = 2 sin^2 or 2 cos^2 of theta / 2, which keeps sin theta accurate at the
    pole of the band's hemisphere (glsl/envmap.glsl env_band_point, the same steps)."""
    north = 2 * j + 1 < hc
    h0, h1 = 0.5 * np.pi * j / hc, 0.5 * np.pi * (j + 1) / hc
    s0 = np.where(north, 2 * np.sin(h0) ** 2, 2 * np.cos(h0) ** 2)
    s1 = np.where(north, 2 * np.sin(h1) ** 2, 2 * np.cos(h1) ** 2)
    s = s0 + (s1 - s0) * t
    return np.where(north, 1.0 - s, s - 1.0), np.sqrt(np.maximum(s * (2.0 - s), 0.0))


def _row_weights(h: int) -> tuple[np.ndarray, np.ndarray]:
    """(a_j, b_j): integrals of sin(theta) times the weights of rows j and j + 1 of a function
    linear in theta between them, theta_j = pi j / (H - 1):
    a = int (t1 - t) / D sin t dt = cos t0 - (sin t1 - sin t0) / D,
    b = int (t - t0) / D sin t dt = (sin t1 - sin t0) / D - cos t1;  a + b = cos t0 - cos t1."""
    t = np.pi * np.arange(h) / (h - 1)
    t0, t1 = t[:-1], t[1:]
    ds = (np.sin(t1) - np.sin(t0)) / (t1 - t0)
    return np.cos(t0) - ds, ds - np.cos(t1)


def _cell_weights(texels: np.ndarray, a: np.ndarray, b: np.ndarray, dphi: float) -> np.ndarray:
    """(H - 1, W) float32 integral of the luminance over each cell's solid angle (sr): the bilinear
    function is linear in phi within a cell, so a row of texels weighs its two columns' mean,
    dphi (a_j (L[j, i] + L[j, i+1]) + b_j (L[j+1, i] + L[j+1, i+1])) / 2 (:func:`_row_weights`).
    float32 (2^-24 relative) is exact enough: these weights only shape the sampling density; the
    pdf is what the float32 tables realise (alias.realised), whatever the weights' rounding."""
    half = texels @ (0.5 * LUMINANCE).astype(np.float32)         # (H, W): no sum below overflows
    pair = np.empty_like(half)                                   # cell i: columns i, i + 1
    flat = half.reshape(-1)
    np.add(flat[:-1], flat[1:], out=pair.reshape(-1)[:-1])       # contiguous; the last column:
    np.add(half[:, -1], half[:, 0], out=pair[:, -1])             # periodic in u
    weight = pair[:-1] * (dphi * a).astype(np.float32)[:, None]
    pair[1:] *= (dphi * b).astype(np.float32)[:, None]           # rows 1 .. H-1, after their use above
    weight += pair[1:]
    return weight


def _rotation(to_world, where: str) -> np.ndarray:
    """``to_world`` as an orthogonal 3 x 3 matrix (a 4 x 4 transform's linear part; a uniform
    scale divided out); refused otherwise, since a shear or a non-uniform scale has no meaning
    for directions at infinity."""
    if to_world is None:
        return np.eye(3)
    m = np.asarray(to_world, np.float64)
    if m.shape == (4, 4):
        m = m[:3, :3]
    if m.shape != (3, 3) or not np.isfinite(m).all():
        raise EnvMapError(f"{where}: to_world must be a 3 x 3 (or 4 x 4) finite matrix, got shape {m.shape}")
    det = np.linalg.det(m)
    if abs(det) < 1e-12:
        raise EnvMapError(f"{where}: to_world is singular")
    m = m / np.cbrt(abs(det))
    if np.abs(m @ m.T - np.eye(3)).max() > 1e-4:
        raise EnvMapError(f"{where}: to_world must be a rotation (a mirror or a uniform scale allowed); "
                          f"it shears or scales unevenly")
    return m


def _pad(img: np.ndarray) -> np.ndarray:
    """Mitsuba's Bitmap::pad_to(2, 3): repeat the last column, then the last row."""
    h, w = img.shape[:2]
    if w < MIN_WIDTH:
        img = np.concatenate([img, np.repeat(img[:, -1:], MIN_WIDTH - w, axis=1)], axis=1)
    if h < MIN_HEIGHT:
        img = np.concatenate([img, np.repeat(img[-1:], MIN_HEIGHT - h, axis=0)], axis=0)
    return img


def _scaled(image, scale, where: str) -> np.ndarray:
    img = np.asarray(image, np.float32)
    if img.ndim == 2:
        img = np.repeat(img[:, :, None], 3, axis=2)
    if img.ndim != 3 or img.shape[2] != 3 or img.shape[0] < 1 or img.shape[1] < 1:
        raise EnvMapError(f"{where}: an environment map is an (H, W, 3) RGB image, got shape {img.shape}")
    if img.shape[0] * img.shape[1] > MAX_ENV_TEXELS:
        raise EnvMapError(f"{where}: {img.shape[1]} x {img.shape[0]} texels exceed {MAX_ENV_TEXELS} (2^26)")
    s = np.broadcast_to(np.asarray(scale, np.float64), (3,)) if np.size(scale) in (1, 3) else None
    if s is None or not np.isfinite(s).all() or (s < 0).any():
        raise EnvMapError(f"{where}: scale must be one or three finite non-negative numbers, got {scale!r}")
    hi = check_texels(img, where)
    if (s == s[0]).all():  # one factor: a scalar product (3x faster than broadcasting RGB)
        out = img if s[0] == 1.0 else img * np.float32(s[0])
    else:
        out = img * s.astype(np.float32)
    # Overflow is possible only near float32's top: look at the scaled texels only then.
    if hi * s.max() > 0.5 * float(np.finfo(np.float32).max) and not np.isfinite(float(out.max())):
        raise EnvMapError(f"{where}: scale {scale!r} makes texels overflow float32")
    return _pad(np.ascontiguousarray(out, np.float32))


def build_envmap(image, scale=1.0, to_world=None, name: str = "environment map") -> EnvMap:
    """An :class:`EnvMap` from an (H, W, 3) linear RGB image (row 0 = top = +Y), a radiance
    ``scale`` (one number or RGB) and ``to_world`` (3 x 3 or 4 x 4, a rotation; None: identity).
    ``name`` starts the one-line :class:`EnvMapError` messages (the file or the scene key)."""
    texels = _scaled(image, scale, name)
    rot = _rotation(to_world, name)
    h, w = texels.shape[:2]
    a, b = _row_weights(h)
    dphi = 2.0 * np.pi / w
    weight = _cell_weights(texels, a, b, dphi)                        # (H-1, W) float32
    # The column pairs of a row of cells add up to the row's sum (periodic in u). (H, 3) row
    # sums by a float32 matrix product (BLAS, 3x faster than a float64 sum of a transposed copy;
    # ~2e-6 relative: the integral is a light-selection power, not a pdf).
    rows = (np.ones(w, np.float32) @ texels).astype(np.float64)
    integral = dphi * (a @ rows[:-1] + b @ rows[1:])
    solid = dphi * (a + b)                                            # solid angle of a cell per row
    row_sum = weight.sum(axis=1, dtype=np.float64)
    if not row_sum.sum() > 0.0:  # black: sample uniformly (its radiance is 0 anyway; no 0/0)
        weight = np.broadcast_to(solid[:, None], weight.shape).astype(np.float32)
        row_sum = weight.sum(axis=1, dtype=np.float64)
    live = row_sum > 0.0  # a black row: its cells uniform (never picked: the row's weight is 0)
    if not live.all():
        weight[~live] = 1.0
    row_q, row_alias = build_alias(row_sum[None])
    col_q, col_alias = build_alias(weight)
    # The probabilities the shader's float32 tables realise, per solid angle.
    p_row = realised(row_q, row_alias, h - 1)[0]
    p_cell = realised(col_q, col_alias, w)
    p_cell *= (p_row / solid)[:, None]
    cell_pdf = p_cell.astype(np.float32)
    return EnvMap(texels, rot, row_q[0], row_alias[0], col_q, col_alias, cell_pdf, integral)


def load_envmap(path, scale=1.0, to_world=None) -> EnvMap:
    """:func:`build_envmap` of the image file ``path`` (:func:`read_envmap`), errors naming it."""
    return build_envmap(read_envmap(path), scale, to_world, name=str(path))

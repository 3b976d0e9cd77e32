"""Sensor, film, sampler and integrator of a Mitsuba 3 scene -> mcpt's ``camera`` and ``render``.

* ``perspective``: ``fov`` with ``fov_axis`` (x default, y, diagonal, smaller, larger) or
  ``focal_length`` (35 mm film: the diagonal 43.27 mm; default 50mm), reduced to Mitsuba's
  horizontal fov (``mi.parse_fov``) and then to mcpt's vertical one, exactly:
  ``tan(vfov/2) = tan(xfov/2) / aspect``. ``to_world`` gives position = M·0, view direction =
  M's third column, up = its second column (Mitsuba's camera looks along local +z with local +x
  the image's LEFT, so mcpt's right = forward x up is Mitsuba's -x: the same image).
* ``thinlens``: the same, plus ``aperture_radius`` and ``focus_distance`` -> ``camera.lens``
  (world units, exactly: the focus plane, the concentric disk; src/sensors/thinlens.cpp).
* ``orthographic``: ``to_world``'s x/y scale s sets the view (Mitsuba: x in [-s, s], y in
  [-s/aspect, s/aspect]) -> ``projection: orthographic``, ``ortho_height = 2 s / aspect``.
* ``hdrfilm`` / ``specfilm``: ``width`` / ``height`` (default 768 x 576); ``rfilter`` ``box``,
  ``tent`` (``radius``) and ``gaussian`` (``stddev``; the default filter) -> ``camera.filter``
  exactly (filter importance sampling: mcpt/shading/pixel_filter.py); others are refused.
* any sampler: ``sample_count`` (default 4) -> ``spp``; ``seed`` -> ``seed``.
* ``path`` and the integrators whose expected image is the same: ``max_depth`` (default -1) ->
  ``bounces = max_depth - 1``; -1 (unlimited) -> :data:`UNLIMITED_BOUNCES`.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from ...shading.pixel_filter import FILTERS, GAUSS_RADIUS_STDDEVS
from ..fields import MAX_RESOLUTION
from ..pixel_filter import MAX_RADIUS
from . import values as V
from .xmltree import Node

log = logging.getLogger("mcpt")

#: Bounces for ``max_depth = -1`` (Mitsuba: unlimited, ended by Russian roulette only). mcpt ends
#: paths by roulette too (glsl/path_state.glsl); 64 scattering events leave a path at most
#: 0.95^64 = 4 % of its throughput even at albedo 0.95, and far less in any real scene.
UNLIMITED_BOUNCES = 64
#: 35 mm film diagonal (mm), which Mitsuba's ``focal_length`` refers to.
FILM_DIAGONAL_MM = math.hypot(36.0, 24.0)

#: Integrators whose expected image is the path tracer's (they differ in noise only).
SAME_IMAGE = ("volpath", "volpathmis", "prb", "prb_basic", "direct_projective", "prb_projective",
              "ptracer", "bdpt")
SUPPORTED_INTEGRATORS = ("path", "direct") + SAME_IMAGE
SUPPORTED_FILMS = ("hdrfilm", "specfilm")


def x_fov(props: dict[str, Node], aspect: float, sensor: Node) -> float:
    """Mitsuba's ``parse_fov``: the horizontal field of view (degrees) for ``aspect = W / H``."""
    if "fov" in props and "focal_length" in props:
        raise sensor.error("give fov or focal_length, not both (as Mitsuba requires)")
    if "fov" in props:
        fov = V.as_float(props["fov"])
        axis = V.as_string(props["fov_axis"]).lower() if "fov_axis" in props else "x"
        if axis == "smaller":
            axis = "y" if aspect > 1 else "x"
        elif axis == "larger":
            axis = "x" if aspect > 1 else "y"
    else:
        text = V.as_string(props["focal_length"]) if "focal_length" in props else "50mm"
        mm = text[:-2] if text.endswith("mm") else text
        try:
            f = float(mm)
        except ValueError:
            raise props["focal_length"].error(f"focal_length={text!r}: expected <x>mm") from None
        if not f > 0:
            raise props["focal_length"].error(f"focal_length={text!r} must be positive")
        fov, axis = 2.0 * math.degrees(math.atan(FILM_DIAGONAL_MM / (2.0 * f))), "diagonal"
    if not 0.0 < fov < 180.0:
        raise (props.get("fov") or sensor).error(f"fov {fov} must lie in (0, 180) degrees")
    t = math.tan(math.radians(fov) / 2.0)
    if axis == "x":
        return fov
    if axis == "y":
        return 2.0 * math.degrees(math.atan(t * aspect))
    if axis == "diagonal":
        return 2.0 * math.degrees(math.atan(t * aspect / math.sqrt(1.0 + aspect * aspect)))
    raise props["fov_axis"].error(f"fov_axis {axis!r}: expected x, y, diagonal, smaller or larger")


def vfov_deg(xfov: float, aspect: float) -> float:
    """mcpt's vertical fov (degrees) from the horizontal one: tan(v/2) = tan(x/2) / aspect."""
    return 2.0 * math.degrees(math.atan(math.tan(math.radians(xfov) / 2.0) / aspect))


def camera_pose(m: np.ndarray, where: Node) -> dict:
    """``position``, ``look_at`` (one unit ahead) and ``up`` from a sensor's ``to_world``; a
    matrix with shear, non-uniform scale or a mirror is refused (mcpt's camera cannot say it)."""
    a = m[:3, :3]
    if not np.allclose(m[3], [0, 0, 0, 1]):
        raise where.error("to_world is projective; a camera needs an affine one")
    gram = a.T @ a
    scale = float(np.mean(np.diag(gram)))
    if scale <= 0 or not np.allclose(gram, scale * np.eye(3), rtol=1e-6, atol=1e-9 * scale):
        raise where.error("to_world has shear or non-uniform scale; mcpt's camera (position, look_at, "
                          "up) cannot express it")
    if np.linalg.det(a) < 0:
        raise where.error("to_world mirrors the image (negative determinant, e.g. <scale x=\"-1\"/>); "
                          "mcpt's camera cannot mirror")
    pos = m[:3, 3]
    fwd = a[:, 2] / np.linalg.norm(a[:, 2])
    up = a[:, 1] / np.linalg.norm(a[:, 1])
    return {"position": pos.tolist(), "look_at": (pos + fwd).tolist(), "up": up.tolist()}


def film(node: Node | None) -> tuple[int, int, dict]:
    """(width, height, pixel filter) of the film."""
    if node is None:
        return 768, 576, pixel_filter(None)
    if node.get("type") not in SUPPORTED_FILMS:
        raise node.error(f"not supported by mcpt (supported films: {', '.join(SUPPORTED_FILMS)})")
    props = V.properties(node)
    size = []
    for key, default in (("width", 768), ("height", 576)):
        n = V.as_int(props[key]) if key in props else default
        if not 1 <= n <= MAX_RESOLUTION:
            raise props[key].error(f"{key} {n} out of range 1..{MAX_RESOLUTION}")
        size.append(n)
    for key in ("crop_offset_x", "crop_offset_y", "crop_width", "crop_height"):
        if key in props:
            raise props[key].error("film crops are not supported by mcpt")
    rfilter = next((c for c in node.children if c.tag == "rfilter"), None)
    return size[0], size[1], pixel_filter(rfilter)


def pixel_filter(node: Node | None) -> dict:
    """mcpt's ``camera.filter`` for an ``<rfilter>`` (absent: Mitsuba's default, gaussian):
    box, tent (``radius``, default 1) and gaussian (``stddev``, default 0.5) exactly; others refused."""
    if node is None:
        return {"type": "gaussian"}
    kind = node.get("type")
    params = {"tent": "radius", "gaussian": "stddev"}
    if kind not in FILTERS:
        raise node.error(f"pixel filter {kind!r} is not supported by mcpt (supported: {', '.join(FILTERS)})")
    props = V.properties(node)
    out: dict = {"type": kind}
    for key, value in props.items():
        if key != params.get(kind):
            raise value.error(f"{key}: not a parameter of the {kind} filter")
        out[key] = V.as_float(value)
        support = out[key] * (GAUSS_RADIUS_STDDEVS if key == "stddev" else 1.0)
        if not 0.0 < support <= MAX_RADIUS:
            raise value.error(f"{key} {out[key]:g}: the filter's radius must lie in (0, {MAX_RADIUS:g}] pixels")
    return out


def sampler(node: Node | None) -> dict:
    """``spp`` (and ``seed``) from a sampler of any type (mcpt draws its own sequence)."""
    if node is None:
        return {"spp": 4}
    props = V.properties(node)
    out = {"spp": V.as_int(props["sample_count"]) if "sample_count" in props else 4}
    if out["spp"] < 1:
        raise props["sample_count"].error("sample_count must be at least 1")
    if "seed" in props:
        out["seed"] = V.as_int(props["seed"])
    return out


def integrator(node: Node | None) -> int:
    """mcpt's ``bounces`` for the integrator (default ``path``, max_depth -1)."""
    kind = node.get("type") if node is not None else "path"
    if kind not in SUPPORTED_INTEGRATORS:
        raise node.error(f"not supported by mcpt: its image differs from a path tracer's "
                         f"(supported: {', '.join(SUPPORTED_INTEGRATORS)})")
    props = V.properties(node) if node is not None else {}
    if "hide_emitters" in props and V.as_bool(props["hide_emitters"]):
        raise props["hide_emitters"].error("hide_emitters is not supported by mcpt (emitters are visible)")
    if kind == "direct":
        key = "emitter_samples" if "emitter_samples" in props else "shading_samples"
        if key in props and V.as_int(props[key]) > 1:
            # mitsuba3 src/integrators/direct.cpp: a delta emitter's sample gets MIS weight 1,
            # not 1/emitter_samples, so each of the N samples counts fully (hello.xml: 4x).
            log.warning("%s:%d: %s: %s=%d: Mitsuba 3 counts each sample of a point, spot or "
                        "directional light fully (direct.cpp), so its image of them is %d times "
                        "brighter; mcpt renders the expected image", node.file, node.line,
                        node.label, key, V.as_int(props[key]), V.as_int(props[key]))
        return 1
    if kind in SAME_IMAGE:
        log.warning("%s:%d: %s: rendered with mcpt's path tracer (the same expected image)",
                    node.file, node.line, node.label)
    depth = V.as_int(props["max_depth"]) if "max_depth" in props else -1
    if depth == -1:
        return UNLIMITED_BOUNCES
    if depth < 1:
        raise props["max_depth"].error(f"max_depth {depth}: mcpt needs at least 1 (emitters seen "
                                       "directly) or -1 (unlimited)")
    return depth - 1


SUPPORTED_SENSORS = ("perspective", "thinlens", "orthographic")


def lens(props: dict[str, Node], node: Node, m: np.ndarray) -> dict:
    """``camera.lens`` of a ``thinlens``: ``aperture_radius`` (required, as in Mitsuba) and
    ``focus_distance`` (Mitsuba's default: far_clip, 1e4), world units."""
    if "aperture_radius" not in props:
        raise node.error("a thinlens sensor needs aperture_radius (as Mitsuba requires)")
    if not np.allclose(np.linalg.norm(m[:3, :3], axis=0), 1.0, rtol=1e-5):
        raise props.get("to_world", node).error("to_world of a thinlens has a scale (Mitsuba refuses it too)")
    out = {"aperture_radius": V.as_float(props["aperture_radius"]),
           "focus_distance": V.as_float(props["focus_distance"]) if "focus_distance" in props else 1e4}
    if not out["aperture_radius"] >= 0.0:
        raise props["aperture_radius"].error(f"aperture_radius {out['aperture_radius']:g} must be >= 0")
    if not out["focus_distance"] > 0.0:
        raise props["focus_distance"].error(f"focus_distance {out['focus_distance']:g} must be > 0")
    return out


def ortho_view(m: np.ndarray, aspect: float, where: Node) -> dict:
    """Pose and ``ortho_height`` of an ``orthographic`` sensor: Mitsuba's view is x in [-1, 1],
    y in [-1/aspect, 1/aspect] in camera space, stretched by to_world's scale (z scale unused)."""
    a = m[:3, :3]
    n = np.linalg.norm(a, axis=0)
    unit = a / n
    if not np.allclose(m[3], [0, 0, 0, 1]) or not np.allclose(unit.T @ unit, np.eye(3), atol=1e-6):
        raise where.error("to_world of an orthographic sensor must be a rotation with scale (no shear)")
    if not np.isclose(n[0], n[1], rtol=1e-6):
        raise where.error(f"to_world scales x and y differently ({n[0]:g}, {n[1]:g}): mcpt's pixels are square")
    if np.linalg.det(a) < 0:
        raise where.error("to_world mirrors the image (negative determinant); mcpt's camera cannot mirror")
    pos = m[:3, 3]
    return {"position": pos.tolist(), "look_at": (pos + unit[:, 2]).tolist(), "up": unit[:, 1].tolist(),
            "projection": "orthographic", "ortho_height": float(2.0 * n[1] / aspect)}


def sensor(node: Node, objects) -> tuple[dict, dict]:
    """(camera dict, render dict) for a ``<sensor>``; ``objects``: its child objects resolved."""
    kind = node.get("type")
    if kind not in SUPPORTED_SENSORS:
        raise node.error(f"not supported by mcpt (supported sensors: {', '.join(SUPPORTED_SENSORS)})")
    props = V.properties(node)
    for key in ("principal_point_offset_x", "principal_point_offset_y"):
        if key in props and V.as_float(props[key]) != 0.0:
            raise props[key].error("off-centre principal points are not supported by mcpt")
    film_node = next((c for c in objects if c.tag == "film"), None)
    width, height, rfilter = film(film_node)
    render = sampler(next((c for c in objects if c.tag == "sampler"), None))
    aspect = width / height
    m = V.as_transform(props["to_world"]) if "to_world" in props else np.eye(4)
    where = props.get("to_world", node)
    if kind == "orthographic":
        camera = ortho_view(m, aspect, where)
    else:
        camera = {**camera_pose(m, where), "vfov_deg": vfov_deg(x_fov(props, aspect, node), aspect)}
    if kind == "thinlens":
        camera["lens"] = lens(props, node, m)
    camera.update(resolution=[width, height], filter=rfilter)
    return camera, render

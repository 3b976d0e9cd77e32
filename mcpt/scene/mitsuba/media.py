"""Mitsuba 3 participating media -> mcpt's ``medium:`` (issue #25; the YAML side:
mcpt/scene/medium.py).

* ``homogeneous``: ``albedo`` (default 0.75) and ``sigma_t`` (default 1), colours or numbers,
  ``scale`` (default 1) -> ``{albedo, density, scale}``; ``sample_emitters`` (mcpt always samples
  them: the same expected image) and ``has_spectral_extinction`` are accepted.
* phase ``hg`` (``g``, default 0.8) and ``isotropic`` (Mitsuba's default) -> ``g``.

A medium the sensor holds (``<ref id=.../>`` or a nested ``<medium>``) fills the scene: Mitsuba's
camera medium, mcpt's scene-wide one, exact while no shape bounds it (shapes with ``interior`` /
``exterior`` media are refused, src/integrators/volpath.cpp changes the medium only there).
Grid media and other phase functions are refused with their line.
"""

from __future__ import annotations

from ..medium import blocked_reason, delta_light
from . import values as V
from .xmltree import Node, deref

_KEYS = ("albedo", "sigma_t", "scale", "sample_emitters", "has_spectral_extinction")


def phase_g(node: Node | None) -> float:
    """g of a <phase> (None: Mitsuba's default, isotropic)."""
    if node is None or node.get("type") == "isotropic":
        return 0.0
    if node.get("type") != "hg":
        raise node.error("not supported by mcpt (supported phase functions: isotropic, hg)")
    props = V.properties(node)
    for name, p in props.items():
        if name != "g":
            raise p.error(f"{name!r} is not a parameter of the hg phase function")
    return V.as_float(props["g"]) if "g" in props else 0.8


def medium(node: Node, ids: dict[str, Node]) -> dict:
    """The YAML ``medium:`` data of a <medium>."""
    if node.get("type") != "homogeneous":
        raise node.error("not supported by mcpt (supported media: homogeneous)")
    props = V.properties(node)
    for name, p in props.items():
        if name not in _KEYS:
            raise p.error(f"{name!r} is not a parameter of a homogeneous medium mcpt maps "
                          f"(mapped: {', '.join(_KEYS)})")
    phase = None
    for child in node.children:
        target = deref(child, ids) if child.tag == "ref" else child
        if target.tag == "phase":
            phase = target
        elif target.tag not in V.PROPERTY_TAGS:
            raise target.error(f"<{target.tag}> inside a medium is not supported by mcpt")
    colour = lambda name, d: list(V.as_color(props[name])) if name in props else [d, d, d]  # noqa: E731
    out = {"albedo": colour("albedo", 0.75), "density": colour("sigma_t", 1.0), "g": phase_g(phase)}
    if "scale" in props:
        out["scale"] = V.as_float(props["scale"])
    return out


def sensor_medium(sensor: Node, ids: dict[str, Node]) -> Node | None:
    """The <medium> a sensor holds (by reference or nested), or None."""
    found = [deref(c, ids) if c.tag == "ref" else c for c in sensor.children if c.tag in ("ref", "medium")]
    found = [m for m in found if m.tag == "medium"]
    if len(found) > 1:
        raise found[1].error("a second medium in the sensor (mcpt takes one)")
    return found[0] if found else None


def shape_material(s, fog: Node | None, ids: dict[str, Node], base) -> dict:
    """The YAML material of shape ``s`` (shapes.py ShapeOut) given its media: ``base()`` (the BSDF's
    own mapping), with ``interior`` for a dielectric, or an index-matched dielectric (ior 1) for
    Mitsuba's ``null`` BSDF around an interior. mcpt's outside of every shape is the scene's
    medium, so a transmitting shape's ``exterior`` must be the sensor's medium (Mitsuba leaves
    vacuum behind a shape without one)."""
    kind = s.bsdf.get("type") if s.bsdf is not None else None
    interior, exterior = s.media.get("interior"), s.media.get("exterior")
    transmits = kind in ("dielectric", "null")
    if exterior is not None and exterior is not fog:
        raise s.node.error("mcpt's outside of every shape is the sensor's medium: an exterior medium must be it")
    if fog is not None and transmits and exterior is None:
        raise s.node.error("a transmitting shape in a scene with a sensor medium needs "
                           "<ref name=\"exterior\"> to it (Mitsuba leaves vacuum behind the shape)")
    if interior is None:
        if kind == "null":
            raise s.bsdf.error("a null BSDF is supported by mcpt only around an interior medium")
        return base()
    if not transmits:
        raise s.node.error("an interior medium needs a dielectric or null BSDF on its shape in mcpt")
    mat = {"type": "dielectric", "ior": 1.0} if kind == "null" else base()
    mat["interior"] = medium(interior, ids)
    return mat


def scene_medium(sensor: Node, shapes, integrator: Node | None, ids: dict[str, Node]) -> Node | None:
    """The sensor's medium (None: none), after checking that the integrator renders media at all
    when the sensor or any shape has one."""
    fog = sensor_medium(sensor, ids)
    any_medium = fog or next((m for s in shapes for m in s.media.values()), None)
    if any_medium is not None:
        kind = integrator.get("type") if integrator is not None else "path"
        if kind not in ("volpath", "volpathmis"):
            raise any_medium.error(f"the {kind} integrator ignores media: render this scene with volpath")
    return fog


def add_medium(data: dict, lines: dict, fog: Node | None, ids: dict[str, Node]) -> None:
    """``data["medium"]`` (and its line) from the sensor's medium, if any."""
    if fog is not None:
        data["medium"] = medium(fog, ids)
        lines[("medium",)] = fog.line


def check_null_lights(shapes, lights: list[dict], lines: dict) -> None:
    """A null BSDF around an interior medium with a delta emitter (point, spot, directional) is
    refused at the shape: mcpt's ior-1 boundary stops that light's shadow rays (mcpt/scene/medium.py)."""
    delta = [(i, light["type"]) for i, light in enumerate(lights)
             if delta_light(light["type"], light.get("angular_diameter_deg"))]
    for s in shapes:
        if delta and s.media.get("interior") is not None and s.bsdf is not None and s.bsdf.get("type") == "null":
            i, kind = delta[0]
            raise s.node.error('<ref name="interior"> (null BSDF): '
                               + blocked_reason(kind, f"(<emitter>, line {lines[('lights', str(i))]})"))

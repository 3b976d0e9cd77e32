"""Participating media on the GPU (issue #25; scene side: mcpt/scene/medium.py; GLSL:
glsl/medium.glsl coefficients, transmittance and free-flight sampling, glsl/medium_scatter.glsl the
medium vertex, glsl/phase_hg.glsl the phase function).

Two kinds, both homogeneous, both uniforms (no table):

* the scene-wide medium (``medium:``): ``u_medium_sigma_t``, ``u_medium_sigma_s`` (RGB, 1 / world
  unit) and ``u_medium_g``; zeros when the scene has none (every ray then passes with weight 1);
* interior media of dielectrics (``interior:`` of a material, at most :data:`MAX_MEDIA`):
  ``u_media_material[i]`` (the material table row whose meshes bound medium i + 1),
  ``u_media_sigma_t[i]`` (sigma_t, g) and ``u_media_sigma_s[i]``. A segment runs inside such a
  medium when it arrives at the back of a triangle of that material (the rule Beer-Lambert
  absorption already follows), so the path carries no medium state from draw to draw; this needs
  closed meshes and no object inside them (:func:`check_closed`).

A scene without any medium compiles the code out (MCPT_MEDIUM 0). Random numbers: the free-flight
distance of the segment to hit k reads dimension ``dims_for(bounces) + k - 1`` (a block after the
bounces' own, so other scenes keep their layout: mcpt/shading/sampler.py), its equiangular distance
(MCPT_MEDIUM_EQUIANGULAR) ``dims_for(bounces) + bounces + k - 1``; the medium vertex reads bounce
k's numbers.
"""

from __future__ import annotations

import numpy as np

from ..errors import McptError

MAX_MEDIA = 8  # glsl/medium.glsl MAX_MEDIA


class MediumError(McptError, ValueError):
    """An interior medium the renderer cannot hold: an open mesh, too many media."""


def interior_media(world) -> list[tuple[int, str, object]]:
    """(material table row, material name, Medium) of every used dielectric with an interior."""
    mats, names = world.scene.materials, world.materials.names
    used = set(world.materials.used(world.material_ids))
    return [(i, n, mats[n].interior) for i, n in enumerate(names)
            if i in used and n in mats and mats[n].type == "dielectric" and mats[n].interior is not None]


def check_closed(world, media) -> None:
    """Every material bounding an interior medium covers closed surfaces: each edge (vertices
    matched by position) is shared by an even number of its triangles. One located line if not."""
    if len(media) > MAX_MEDIA:
        raise MediumError(f"{world.scene.where('materials', media[MAX_MEDIA][1], 'interior')}: more than "
                          f"{MAX_MEDIA} materials with an interior medium")
    for row, name, _ in media:
        tris = world.tris[world.tri_material == row]
        _, vid = np.unique(tris.reshape(-1, 3), axis=0, return_inverse=True)
        v = vid.reshape(-1, 3)
        edges = np.sort(np.concatenate([v[:, [0, 1]], v[:, [1, 2]], v[:, [2, 0]]]), axis=1)
        _, counts = np.unique(edges, axis=0, return_counts=True)
        open_edges = int((counts % 2 == 1).sum())
        if open_edges:
            raise MediumError(f"{world.scene.where('materials', name, 'interior')}: the meshes of material "
                              f"{name!r} are open ({open_edges} edges with one triangle): an interior medium "
                              "needs closed meshes")


def medium_uses(world) -> dict:
    """The Uses fields of media (mcpt/gpu/features.py): ``medium`` (any medium: the code) and
    ``interior_media`` (some dielectric bounds one); checks the interiors' meshes."""
    media = interior_media(world)
    check_closed(world, media)
    return {"medium": world.scene.medium is not None or bool(media), "interior_media": bool(media)}


def equiangular_used(uses, nee: bool, switch: bool) -> bool:
    """Equiangular sampling (Kulla & Fajardo 2012) is compiled in: a medium, light sampling and
    some point or spot light (the lights whose in-scattering it concentrates), unless switched off."""
    return bool(switch and nee and uses.medium and (uses.point_lights or uses.spot_lights))


def medium_dims(bounces: int, medium: bool, equiangular: bool = False) -> int:
    """Random dimensions the medium adds: one free-flight distance per bounce (and one
    equiangular distance per bounce)."""
    return int(bounces) * (1 + int(equiangular)) if medium else 0


def _rgb(v) -> tuple:
    return tuple(float(x) for x in v)


def medium_uniforms(world, interior: bool) -> dict:
    """The uniforms of glsl/medium.glsl (``interior``: the program holds interior media)."""
    medium = world.scene.medium
    if medium is None:
        out = {"u_medium_sigma_t": (0.0, 0.0, 0.0), "u_medium_sigma_s": (0.0, 0.0, 0.0), "u_medium_g": 0.0}
    else:
        sigma_t, sigma_s = medium.coefficients
        out = {"u_medium_sigma_t": _rgb(sigma_t), "u_medium_sigma_s": _rgb(sigma_s), "u_medium_g": float(medium.g)}
    if interior:
        media = interior_media(world)
        mat = [-1] * MAX_MEDIA
        st, ss = [(0.0,) * 4] * MAX_MEDIA, [(0.0,) * 3] * MAX_MEDIA
        for i, (row, _, m) in enumerate(media):
            sigma_t, sigma_s = m.coefficients
            mat[i], st[i], ss[i] = row, (*_rgb(sigma_t), float(m.g)), _rgb(sigma_s)
        out.update(u_media_count=len(media), u_media_material=mat, u_media_sigma_t=st, u_media_sigma_s=ss)
    return out

"""Watertightness through the real GPU traversal: no ray escapes a closed mesh."""

from __future__ import annotations

import numpy as np

from mcpt.gpu.features import for_world
from mcpt.gpu.pack import pack
from mcpt.scene.shipped import shipped

from .core import Env, Outcome, case, make_scene, write_obj
from .furnace import sphere_mesh

SPHERE_OBJ = shipped("furnace/sphere_inward.obj")
CORNELL_YAML = shipped("cornell-box.yaml")
FURNACE_YAML = shipped("furnace.yaml")
FLT_MAX = float(np.finfo(np.float32).max)



# ---- watertightness through the real GPU traversal ---------------------------------------------

def trace(env: Env, world, origins: np.ndarray, dirs: np.ndarray):
    """Closest hits of camera-relative rays through glsl/bvh.glsl (probe_trace.frag):
    (t, triangle index in the world's order, or -1)."""
    from ..probe import run_probe

    feats = for_world(world)
    bufs = pack(world, feats).buffers
    tbos = {k: bufs[k] for k in ("tris", "nodes") if k in bufs}
    probe = np.zeros((2 * len(origins), 4), np.uint32)
    probe[0::2, :3] = np.asarray(origins, np.float32).view(np.uint32)
    probe[1::2, :3] = np.asarray(dirs, np.float32).view(np.uint32)
    out = run_probe(env.gl, "probe_trace.frag", probe, len(origins), preamble=feats.preamble(),
                    key=("stability-trace", feats.key), tbos=tbos,
                    uniforms={"u_tri_count": world.n_triangles})
    t = np.where(out[:, 1] > 0, out[:, 0].view(np.float32), np.inf)
    return t, out[:, 1].astype(np.int64) - 1


def mesh_world(env: Env, name: str, vertices, faces, *, camera=(0.0, 0.0, 0.0), look=(0, 0, -1)):
    """A World holding one mesh (written with full float64 precision), camera at ``camera``."""
    from mcpt.shapes.world import load_world

    path = write_obj(env.file(f"{name}.obj"), vertices, faces)
    cam = [float(x) for x in camera]
    sc = make_scene(env, name, camera={"position": cam, "look_at": [c + d for c, d in zip(cam, look)],
                                       "vfov_deg": 60, "resolution": [8, 8]},
                    materials={"m": {"albedo": [0.5, 0.5, 0.5], "emission": [1, 1, 1]}},
                    meshes=[{"file": path, "material": "m"}])
    return load_world(sc)


def _topology(tris32: np.ndarray):
    """Vertices (float64 of the float32 values), faces, unique edges of a triangle soup."""
    v, inv = np.unique(tris32.reshape(-1, 3), axis=0, return_inverse=True)
    faces = inv.reshape(-1, 3)
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    return v.astype(np.float64), faces, np.unique(e, axis=0)


def _unit32(d: np.ndarray) -> np.ndarray:
    return (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32).astype(np.float64)


def _mt_misses(o, d, tris32, faces, vertex_of_ray, edge_of_ray) -> int:
    """How many rays Moeller-Trumbore in float32 (det != 0) would let through: each ray tested
    against the triangles sharing the vertex or edge it is aimed at (informational)."""
    nf = len(faces)
    corner_v = faces.reshape(-1)
    corner_f = np.repeat(np.arange(nf), 3)
    pairs_r, pairs_f = [], []
    vr = np.flatnonzero(vertex_of_ray >= 0)
    if vr.size:
        order = np.argsort(corner_v, kind="stable")
        cv, cf = corner_v[order], corner_f[order]
        lo = np.searchsorted(cv, vertex_of_ray[vr], "left")
        hi = np.searchsorted(cv, vertex_of_ray[vr], "right")
        for r, a, b in zip(vr, lo, hi):
            pairs_r += [r] * (b - a)
            pairs_f += cf[a:b].tolist()
    er = np.flatnonzero(edge_of_ray[:, 0] >= 0)
    if er.size:
        fe = np.sort(np.stack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]], 1), axis=2)
        key = fe[..., 0].astype(np.int64) * (1 << 32) + fe[..., 1]
        kf = np.repeat(np.arange(nf), 3)
        key = key.reshape(-1)
        order = np.argsort(key, kind="stable")
        key, kf = key[order], kf[order]
        want = edge_of_ray[er, 0].astype(np.int64) * (1 << 32) + edge_of_ray[er, 1]
        lo = np.searchsorted(key, want, "left")
        hi = np.searchsorted(key, want, "right")
        for r, a, b in zip(er, lo, hi):
            pairs_r += [r] * (b - a)
            pairs_f += kf[a:b].tolist()
    r = np.asarray(pairs_r, np.int64)
    f = np.asarray(pairs_f, np.int64)
    t3 = tris32[f].astype(np.float32)
    o32, d32 = o[r].astype(np.float32), d[r].astype(np.float32)
    with np.errstate(all="ignore"):
        e1, e2 = t3[:, 1] - t3[:, 0], t3[:, 2] - t3[:, 0]
        p = np.cross(d32, e2)
        det = np.einsum("ij,ij->i", e1, p)
        inv = np.float32(1.0) / det
        s = o32 - t3[:, 0]
        u = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1)
        v = np.einsum("ij,ij->i", d32, q) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
        hit = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    hit_ray = np.zeros(len(o), bool)
    hit_ray[r[hit]] = True
    return int((~hit_ray).sum())


def jittered_sphere(amount: float = 0.02, seed: int = 1):
    """The geodesic sphere with every vertex moved radially by up to ``amount``: still closed."""
    v, f = sphere_mesh()
    r = 1.0 + amount * np.random.default_rng(seed).uniform(-1, 1, len(v))
    return v * r[:, None], f


def _watertight_case(name: str, scale: float, camera_distance: float):
    """Rays from inside a closed sphere (radius ``scale``) aimed exactly at its vertices and at
    points on its edges; the camera, hence the coordinate origin after rebasing, sits
    ``camera_distance`` radii from the centre (0: at the centre)."""

    @case(name, "watertight")
    def run(env: Env) -> Outcome:
        v, f = jittered_sphere()
        cam = (0.0, 0.0, camera_distance * scale)
        world = mesh_world(env, name, v * scale, f, camera=cam)
        tris32 = world.tris
        verts, faces, edges = _topology(tris32)
        rng = np.random.default_rng(7)
        centre = verts.mean(axis=0)

        def origins(n):
            u = rng.normal(size=(n, 3))
            u *= (0.5 * scale * rng.random((n, 1)) ** (1 / 3)) / np.linalg.norm(u, axis=1, keepdims=True)
            return (centre + u).astype(np.float32).astype(np.float64)

        nv, ne = len(verts), len(edges)
        t_edge = np.concatenate([np.full(ne, 0.5), rng.uniform(0.02, 0.98, ne)])
        e2 = np.concatenate([edges, edges])
        targets = np.concatenate([verts, verts, verts[e2[:, 0]] + t_edge[:, None] *
                                  (verts[e2[:, 1]] - verts[e2[:, 0]])])
        o = origins(len(targets))
        d = _unit32(targets - o)
        vertex_of_ray = np.concatenate([np.arange(nv), np.arange(nv), np.full(2 * ne, -1)])
        edge_of_ray = np.concatenate([np.full((2 * nv, 2), -1), e2])
        t, tri = trace(env, world, o, d)
        miss = ~np.isfinite(t)
        n_v, n_e = int(miss[: 2 * nv].sum()), int(miss[2 * nv:].sum())
        mt = _mt_misses(o, d, tris32, faces, vertex_of_ray, edge_of_ray)
        return Outcome(f"0 of {len(o)} rays escape ({2 * nv} at vertices, {2 * ne} at edges)",
                       f"{n_v} + {n_e} escape (Moeller-Trumbore float32 would let {mt} through)",
                       n_v + n_e == 0)
    return run


_watertight_case("watertight-sphere-scale-1", 1.0, 0.0)
_watertight_case("watertight-sphere-scale-1e-4", 1e-4, 0.0)
_watertight_case("watertight-sphere-scale-1e4", 1e4, 0.0)
_watertight_case("watertight-sphere-1e3-from-origin", 1.0, 1e3)
_watertight_case("watertight-sphere-1e4-from-origin", 1.0, 1e4)


@case("watertight-quad-diagonal", "watertight")
def _quad_diagonal(env: Env) -> Outcome:
    """A non-planar quad split on its diagonal; 1024 perspective rays aimed at the diagonal."""
    v = np.array([[-1.0, -1.0, -3.0], [1.1, -0.9, -3.3], [0.9, 1.2, -2.6], [-1.05, 0.95, -3.1]])
    world = mesh_world(env, "quad-diagonal", v, np.array([[0, 1, 2], [0, 2, 3]]))
    a, c = world.tris.reshape(-1, 3)[0].astype(np.float64), None
    verts, _, _ = _topology(world.tris)
    # The diagonal is the edge shared by both triangles.
    shared = [p for p in verts if (np.all(world.tris[0] == p, axis=1).any()
                                   and np.all(world.tris[1] == p, axis=1).any())]
    a, c = np.asarray(shared[0]), np.asarray(shared[1])
    s = (np.arange(1024) + 0.5) / 1024
    targets = a + s[:, None] * (c - a)
    o = np.zeros_like(targets)
    t, _ = trace(env, world, o, _unit32(targets))
    miss = int((~np.isfinite(t)).sum())
    return Outcome("0 of 1024 rays escape", f"{miss} escape", miss == 0)


@case("watertight-flat-grid-axis-rays", "watertight")
def _flat_grid(env: Env) -> Outcome:
    """Axis-aligned rays (two zero direction components) onto a flat 16x16 grid of quads at
    z = -1: every BVH box is flat and every ray runs exactly along box faces."""
    n = 16
    g = np.linspace(-1.0, 1.0, n + 1)
    x, y = np.meshgrid(g, g, indexing="ij")
    v = np.stack([x.ravel(), y.ravel(), np.full(x.size, -1.0)], 1)
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    f = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    world = mesh_world(env, "flat-grid", v, f)
    h = (g[1:] + g[:-1]) / 2
    pts = [np.stack(np.meshgrid(p, q, indexing="ij"), -1).reshape(-1, 2)
           for p, q in ((g, g), (h, g), (g, h))]   # vertices, horizontal and vertical edge points
    xy = np.concatenate(pts).astype(np.float32).astype(np.float64)
    o = np.concatenate([xy, np.zeros((len(xy), 1))], 1)
    d = np.tile([0.0, 0.0, -1.0], (len(o), 1))
    t, _ = trace(env, world, o, d)
    inside = np.all(np.abs(xy) <= 1.0, axis=1)
    miss = int((~np.isfinite(t[inside])).sum())
    bad_t = int(np.sum(np.abs(t[inside][np.isfinite(t[inside])] - 1.0) > 1e-6))
    return Outcome(f"0 of {int(inside.sum())} rays escape, all at t = 1",
                   f"{miss} escape, {bad_t} at a wrong t", miss == 0 and bad_t == 0)

"""Ray sorting across a draw, measured on the traversal alone (issue #23: "ray sorting by direction
across a draw ... measure each").

mcpt traces a path's rays where its pixel is shaded, so a SIMD batch (llvmpipe: 4x2 pixels) holds
the rays of neighbouring pixels, and after a diffuse bounce those go anywhere (bench/counters.py:
23 % of the lane slots work). A wavefront tracer could regroup each bounce's rays before tracing
them. This tool measures what each grouping key would buy the traversal: it makes one set of
realistic rays per kind on the host (camera rays traced on the GPU, two cosine-weighted diffuse
bounces from their hits, and shadow rays from the second hits to random points of the lights),
then traces each set through the renderer's own traversal (bench/glsl/probe_trace.frag, the
scene's compiled features) in several orders, each order laid out so that consecutive rays share
a 4x2 batch:

    pixel order       as the renderer has them: the ray of pixel (x, y) at (x, y)
    random            no order at all
    origin morton     sorted by the Morton code of the origin (10 bits an axis)
    origin+dir morton ... of origin and direction (5 bits each of 6 axes)
    enters mesh box   rays that enter the box of the scene's dense mesh first (the BVH root's
                      left subtree; the large triangles are tested written out, glsl/bvh.glsl)
    box, then morton  that, then origin+direction Morton order within each class

and prints each order's lane utilization (the counters build) and its CPU and wall time,
alternating the orders over ``--rounds``.

    python -m mcpt.bench.ray_order --scene sphere100k --size 512 --rounds 4

What it leaves out, so the times are the traversal's alone: the sort itself, the ray state a
wavefront reads and writes around each bounce, and the shading, which keeps its pixel order.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from mcpt.gpu.context import shared_context
from mcpt.gpu.features import for_world
from mcpt.gpu.pack import pack
from mcpt.scene import load_scene
from mcpt.shading.camera import basis
from mcpt.shapes.world import load_world

from .ab import scene_path
from .common import alternate
from .probe import run_probe

#: Probe texels: origin (+ shadow-ray length bits in w), direction (bench/glsl/probe_trace.frag).
PROBE = "probe_trace.frag"
#: Indices of bench/counters.py FIELDS read here.
ITERATIONS, BATCH_256, LANES = 1, 6, 7


class Tracer:
    """The scene's traversal as a probe: ``trace(origins, directions[, lengths])``."""

    def __init__(self, gl, world, width: int):
        self.gl, self.world, self.width = gl, world, width
        self.features = for_world(world)
        packed = pack(world, self.features)
        self.tbos = {k: packed.buffers[k] for k in ("nodes", "tris")}

    def trace(self, o, d, length=None, *, counters: bool = False):
        """Hits (t bits, triangle + 1, bary bits; 0: a miss) or, with ``length``, (1 if visible, ...);
        with ``counters`` also the lane utilization of the traversal loop."""
        feats = self.features.replace(counters=True) if counters else self.features
        pre = feats.preamble() + ("\n#define PROBE_VISIBLE 1" if length is not None else "")
        probe = np.zeros((2 * len(o), 4), np.uint32)
        probe[0::2, :3] = np.asarray(o, np.float32).view(np.uint32)
        probe[1::2, :3] = np.asarray(d, np.float32).view(np.uint32)
        if length is not None:
            probe[0::2, 3] = np.asarray(length, np.float32).view(np.uint32)
        buf = None
        if counters:
            buf = self.gl.ctx.buffer(np.zeros(8, np.uint32).tobytes())
            buf.bind_to_storage_buffer(1)  # bench/counters.py BINDING
        try:
            out = run_probe(self.gl, PROBE, probe, len(o), preamble=pre, key=("ray_order", pre),
                            tbos=self.tbos, uniforms={"u_tri_count": self.world.n_triangles},
                            width=self.width)
            if not counters:
                return out, None
            c = np.frombuffer(buf.read(), np.uint32).astype(np.float64)
        finally:
            if buf is not None:
                buf.release()
        batch = c[BATCH_256] / 256.0
        return out, (c[ITERATIONS] / (c[LANES] * batch) if c[LANES] and batch else None)


def camera_rays(camera, width: int, height: int):
    """Pixel-centre rays, rows from the top (the host twin of glsl/camera.glsl's pinhole)."""
    f, r, u = basis(camera.position, camera.look_at, camera.up, camera.vfov_deg, width, height)
    i, j = np.meshgrid(np.arange(width), np.arange(height))
    d = f + (2.0 * (i + 0.5) / width - 1.0)[..., None] * r + (1.0 - 2.0 * (j + 0.5) / height)[..., None] * u
    d = (d / np.linalg.norm(d, axis=-1, keepdims=True)).reshape(-1, 3)
    return np.zeros_like(d), d


def diffuse_bounce(tracer: Tracer, o, d, alive, rng):
    """Trace (o, d); from each hit of a live ray a cosine-weighted direction about the geometric
    normal (turned to the incoming side); dead rays and misses keep their ray (they miss again)."""
    h, _ = tracer.trace(o, d)
    hit = alive & (h[:, 1] > 0)
    t = h[:, 0].view(np.float32).astype(np.float64)
    v = tracer.world.tris[np.clip(h[:, 1].astype(np.int64) - 1, 0, None)].astype(np.float64)
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-30
    n = np.where((n * d).sum(1, keepdims=True) > 0, -n, n)
    u1, u2 = rng.random(len(o)), rng.random(len(o))
    a = np.where(np.abs(n[:, :1]) > 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    tx = np.cross(n, a)
    tx /= np.linalg.norm(tx, axis=1, keepdims=True)
    ty = np.cross(n, tx)
    r, phi = np.sqrt(u1), 2 * np.pi * u2
    nd = tx * (r * np.cos(phi))[:, None] + ty * (r * np.sin(phi))[:, None] + n * np.sqrt(1 - u1)[:, None]
    x = o + d * t[:, None] + n * 1e-4
    return np.where(hit[:, None], x, o), np.where(hit[:, None], nd, d), hit


def light_rays(world, x, rng):
    """Unit directions and lengths (shortened 0.1 %) from ``x`` to uniform points of emitters."""
    lit = np.flatnonzero((world.materials.emission[world.tri_material] > 0).any(axis=1))
    tri = world.tris[rng.choice(lit, len(x))].astype(np.float64)
    s, t = np.sqrt(rng.random(len(x))), rng.random(len(x))
    p = tri[:, 0] * (1 - s)[:, None] + tri[:, 1] * (s * (1 - t))[:, None] + tri[:, 2] * (s * t)[:, None]
    d = p - x
    length = np.linalg.norm(d, axis=1)
    return d / length[:, None], length * 0.999


def morton(p: np.ndarray, bits: int) -> np.ndarray:
    """Morton codes of the rows of ``p`` (each column scaled to its range, ``bits`` bits each)."""
    span = np.ptp(p, axis=0) + 1e-12
    q = np.clip(np.floor((p - p.min(axis=0)) / span * 2**bits), 0, 2**bits - 1).astype(np.uint64)
    code = np.zeros(len(p), np.uint64)
    for i in range(bits):
        for k in range(p.shape[1]):
            code |= ((q[:, k] >> np.uint64(i)) & np.uint64(1)) << np.uint64(i * p.shape[1] + k)
    return code


def enters_box(o, d, length, lo, hi):
    """Whether each ray (up to ``length``, None: unbounded) enters the box [lo, hi]."""
    inv = 1.0 / np.where(np.abs(d) < 1e-30, 1e-30, d)
    t0, t1 = (lo - o) * inv, (hi - o) * inv
    near = np.maximum(np.minimum(t0, t1).max(axis=1), 0.0)
    far = np.maximum(t0, t1).min(axis=1)
    return near <= (far if length is None else np.minimum(far, length))


def batch_layout(order: np.ndarray, width: int) -> np.ndarray:
    """Probe slots for ``order`` such that each 8 consecutive rays of it fill one 4x2 batch."""
    s = np.arange(len(order))
    block, lane = s // 8, s % 8
    slot = ((block // (width // 4)) * 2 + lane // 4) * width + (block % (width // 4)) * 4 + lane % 4
    out = np.empty(len(order), np.int64)
    out[slot] = order
    return out


def orders(o, d, length, mesh_box, rng) -> dict[str, np.ndarray | None]:
    box = enters_box(o, d, length, *mesh_box)
    od = morton(np.concatenate([o, d], axis=1), 5)
    return {"pixel order": None, "random": rng.permutation(len(o)),
            "origin morton": np.argsort(morton(o, 10), kind="stable"),
            "origin+dir morton": np.argsort(od, kind="stable"),
            "enters mesh box": np.argsort(~box, kind="stable"),
            "box, then morton": np.lexsort((od, ~box))}


def measure(scene_file: Path, size: int, rounds: int, seed: int = 7) -> dict:
    gl = shared_context(None)
    scene = load_scene(scene_file)
    world = load_world(scene)
    tracer = Tracer(gl, world, size)
    rng = np.random.default_rng(seed)
    o, d = camera_rays(scene.camera, size, size)
    x1, d1, alive = diffuse_bounce(tracer, o, d, np.ones(len(o), bool), rng)
    x2, d2, alive = diffuse_bounce(tracer, x1, d1, alive, rng)
    sd, sl = light_rays(world, x2, rng)
    first, _ = world.bvh.large_tail()  # the dense mesh: the triangles before the large ones
    mesh = world.tris[:first].reshape(-1, 3).astype(np.float64)
    mesh_box = (mesh.min(axis=0), mesh.max(axis=0))
    out = {"triangles": world.n_triangles, "rays": len(o), "sets": {}}
    for kind, (ro, rd, rl) in {"bounce": (x2, d2, None), "shadow": (x2, sd, sl)}.items():
        lays = {k: (np.arange(len(ro)) if v is None else batch_layout(v, size))
                for k, v in orders(ro, rd, rl, mesh_box, rng).items()}
        args = {k: (ro[s], rd[s], None if rl is None else rl[s]) for k, s in lays.items()}
        tracer.trace(*args["random"])  # compiled and linked before any order is timed
        cpu, wall, _ = alternate(list(lays), lambda k, r, args=args: tracer.trace(*args[k]), rounds)
        rows = {k: {"utilization": tracer.trace(*a, counters=True)[1], "cpu_s": cpu[k] / rounds,
                    "wall_s": wall[k] / rounds} for k, a in args.items()}
        out["sets"][kind] = {"enters_mesh_box": float(enters_box(ro, rd, rl, *mesh_box).mean()), "orders": rows}
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="sphere100k")
    ap.add_argument("--size", type=int, default=512, help="rays = size^2 (a multiple of 8)")
    ap.add_argument("--rounds", type=int, default=4)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        r = measure(scene_path(args.scene, Path(tmp)), args.size, args.rounds)
    print(f"{args.scene}: {r['triangles']} triangles, {r['rays']} rays a set (second-bounce rays, "
          f"their shadow rays)")
    for kind, body in r["sets"].items():
        rows = body["orders"]
        base = rows["pixel order"]["cpu_s"]
        print(f"{kind}: {body['enters_mesh_box']:.1%} enter the mesh's box")
        for name, row in rows.items():
            print(f"  {name:18s} utilization {row['utilization']:.3f}  CPU {row['cpu_s'] * 1e3:7.1f} ms  "
                  f"wall {row['wall_s'] * 1e3:6.1f} ms  CPU / pixel order {row['cpu_s'] / base:.2f}")


if __name__ == "__main__":
    main()

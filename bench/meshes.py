"""Meshes for the triangle sweep: read an OBJ, subdivide it (4-to-1 midpoint split), write it back.

Only numpy; the output is a plain OBJ (``v``/``f`` lines) that mcpt's loader reads like any other.
Midpoint subdivision keeps the surface exactly (the new vertices lie on the old flat triangles), so
an image of the subdivided mesh is the image of the original: rendering time against triangle count
then measures the BVH, not a change of picture.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def read_obj(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) float64 and triangles (F, 3) int64 (0-based) of an OBJ; polygons are fanned."""
    verts: list[list[float]] = []
    faces: list[list[int]] = []
    with open(path, encoding="utf-8", errors="replace") as fh:
        for line in fh:
            if line.startswith("v "):
                verts.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                idx = [int(tok.split("/")[0]) for tok in line.split()[1:]]
                idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
                for k in range(1, len(idx) - 1):
                    faces.append([idx[0], idx[k], idx[k + 1]])
    return np.asarray(verts, np.float64).reshape(-1, 3), np.asarray(faces, np.int64).reshape(-1, 3)


def subdivide(verts: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One 4-to-1 midpoint split: every triangle becomes four, shared edges share their midpoint."""
    nv = verts.shape[0]
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])  # (3F, 2)
    edges.sort(axis=1)
    uniq, inverse = np.unique(edges, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    mids = 0.5 * (verts[uniq[:, 0]] + verts[uniq[:, 1]])
    f = faces.shape[0]
    m01, m12, m20 = (nv + inverse[i * f:(i + 1) * f] for i in range(3))
    a, b, c = faces[:, 0], faces[:, 1], faces[:, 2]
    new = np.concatenate([np.stack([a, m01, m20], 1), np.stack([m01, b, m12], 1),
                          np.stack([m20, m12, c], 1), np.stack([m01, m12, m20], 1)])
    return np.concatenate([verts, mids]), new


def write_obj(path: str | Path, verts: np.ndarray, faces: np.ndarray, comment: str = "") -> Path:
    """Write positions and 1-based triangles; fast enough for millions of lines (numpy savetxt)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    with open(tmp, "w") as fh:
        if comment:
            fh.write(f"# {comment}\n")
        fh.write(f"# {verts.shape[0]} vertices, {faces.shape[0]} triangles\n")
        np.savetxt(fh, verts, fmt="v %.7g %.7g %.7g")
        np.savetxt(fh, faces + 1, fmt="f %d %d %d")
    tmp.replace(path)  # never leave a half-written file where a later run would trust it
    return path


def subdivided_obj(source: str | Path, levels: int, cache_dir: str | Path) -> Path:
    """``source`` split ``levels`` times, written once into ``cache_dir`` and reused after."""
    source = Path(source)
    if levels == 0:
        return source
    out = Path(cache_dir) / f"{source.stem}-sub{levels}.obj"
    if out.exists() and out.stat().st_mtime >= source.stat().st_mtime:
        return out
    v, f = read_obj(source)
    for _ in range(levels):
        v, f = subdivide(v, f)
    return write_obj(out, v, f, f"{source.name} midpoint-subdivided {levels}x (bench/meshes.py)")


def bounds(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    v, _ = read_obj(path)
    return v.min(axis=0), v.max(axis=0)


def icosphere(levels: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit sphere: an icosahedron split ``levels`` times, vertices pushed onto the sphere
    (20 * 4**levels triangles, counter-clockwise seen from outside)."""
    t = (1.0 + 5.0**0.5) / 2.0
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
                  [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], np.float64)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                  [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
                  [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], np.int64)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    for _ in range(levels):
        v, f = subdivide(v, f)
        v /= np.linalg.norm(v, axis=1, keepdims=True)
    return v, f


def icosphere_obj(levels: int, cache_dir: str | Path) -> Path:
    out = Path(cache_dir) / f"icosphere-{levels}.obj"
    if not out.exists():
        v, f = icosphere(levels)
        write_obj(out, v, f, f"unit icosphere, {levels} subdivisions (bench/meshes.py)")
    return out

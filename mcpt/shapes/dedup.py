"""Repeated triangles: the same surface listed twice (within a file, or across files of a scene).

A light listed twice would be two lights for next-event estimation but one surface for BSDF hits,
counting its direct light twice; a duplicated surface also costs BVH space. mcpt/shapes/mesh.py
drops repeats within a file (by vertex index), mcpt/shapes/world.py across files (by float32 corners).
"""

from __future__ import annotations

import numpy as np


def first_of_duplicates(faces: np.ndarray) -> np.ndarray:
    """Sorted indices of the first occurrence of every triangle, equal up to a cyclic rotation
    of its corners (index based: Assimp's JoinIdenticalVertices gives equal corners equal indices)."""
    if len(faces) < 2:
        return np.arange(len(faces))
    r = np.argmin(faces, axis=1)
    canon = np.take_along_axis(faces, (r[:, None] + np.arange(3)) % 3, axis=1).astype(np.int64)
    n = int(canon.max()) + 1
    if n < 1 << 21:  # one int64 key per triangle
        _, first = np.unique((canon[:, 0] << 42) | (canon[:, 1] << 21) | canon[:, 2], return_index=True)
    else:
        order = np.lexsort((canon[:, 2], canon[:, 1], canon[:, 0]))
        c = canon[order]
        new = np.ones(len(c), bool)
        new[1:] = np.any(c[1:] != c[:-1], axis=1)
        # lexsort is stable, so the first of each run is the earliest occurrence
        first = order[new]
    return np.sort(first)

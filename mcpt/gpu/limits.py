"""What the driver limits and what that means for a scene's paths: llvmpipe's loop budget, the
written-out triangle tables of small scenes, the samples one draw may hold (read by
:mod:`mcpt.gpu.features`, which decides what a program compiles)."""

from __future__ import annotations

import numpy as np

from ..shapes.bvh import SAH_MAX_TRIANGLES
from ..shapes.geometry import shared_edges

#: The buffer-texture size mcpt relies on (issue #24): the GL_MAX_TEXTURE_BUFFER_SIZE that llvmpipe
#: and NVIDIA's drivers report (the GL spec's own minimum, 2^16, holds no real scene). llvmpipe does
#: not clamp a larger buffer, so the upload checks the driver's figure again (tbo.py check_size).
GL_BUFFER_TEXELS = 1 << 27
#: Most triangles a scene may have: the largest buffer per triangle is the BVH's (BVH.gpu_nodes:
#: 3 texels a triangle record, 4 an interior node, 1 pad). The build (bvh_build.py) splits at the
#: median down to leaves of 2 to 4 triangles, at most F/2 interior nodes, except in a subtree of at
#: most SAH_MAX_TRIANGLES triangles split by SAH (down to single triangles) and the root joining the
#: large triangles' subtree: at most F/2 + SAH_MAX_TRIANGLES + 1 nodes, 5 F + 4 (2^18 + 1) + 1
#: texels. A scene above this count is refused before anything is built (mcpt/gpu/scene_size.py).
MAX_TRIANGLES = (GL_BUFFER_TEXELS - 4 * (SAH_MAX_TRIANGLES + 1) - 1) // 5

# Up to this many triangles, a scene without BVH has its count compiled in and its brute-force
# loop written out in full (glsl/bvh.glsl MCPT_TRI_CONST; the shader writes out exactly this many).
TRI_CONST_MAX = 64

# llvmpipe (gallivm's loop limiter) stops the loops of a shader invocation after 65535
# iterations in total; glsl/common.glsl counts them and drops samples that reach it.
LLVMPIPE_LOOP_LIMIT = 65535


# The fewest and most samples per pixel a draw holds (features.samples_per_draw; the most is also
# the read-back chunk of render.py, which a draw never spans).
MIN_SAMPLES_PER_DRAW = 4
MAX_SAMPLES_PER_DRAW = 64


def max_loop_iterations(bounces: int, n_triangles: int, *, traced: bool = True,
                        n_lights: int = 1) -> int:
    """An upper bound on the loop iterations of one path: per ray (a closest-hit and a shadow ray
    per vertex) every node and triangle once (a binary tree has < 2 nodes per triangle) when the
    triangles are reached by a loop (BVH or brute force), none when their tests are written out
    (``traced`` False: MCPT_TRI_CONST without a BVH); per vertex the light CDF's binary search
    (glsl/lights.glsl) and one iteration of the bounce loop."""
    per_ray = 3 * max(n_triangles, 1) if traced else 0
    search = max(n_lights - 1, 0).bit_length() + 1
    return (bounces + 1) * (2 * per_ray + search + 1)


def needs_continuation(loop_limit: int, bounces: int, n_triangles: int, *, traced: bool = True,
                       n_lights: int = 1) -> bool:
    """Whether a path may outrun one draw's share of the loop limit (glsl/path_state.glsl). When
    it cannot (the Cornell box: 36 triangles written out, 8 bounces, < 30 iterations a path), the
    continuation code and its per-draw read-back are left out."""
    worst = MAX_SAMPLES_PER_DRAW * max_loop_iterations(bounces, n_triangles, traced=traced,
                                                       n_lights=n_lights)  # one draw's paths
    return loop_limit > 0 and worst > loop_limit // 4


def loop_limit_for(renderer: str) -> int:
    """The loop-iteration limit of a GL renderer (GL_RENDERER string); 0 when it has none."""
    return LLVMPIPE_LOOP_LIMIT if "llvmpipe" in renderer.lower() else 0


def vertex_tables(vert_addr, tri_vert_ids, vert_pos=()) -> str:
    """The defines of glsl/bvh.glsl's written-out brute-force loop (small scenes): each distinct
    vertex's u_tris texel and each corner's distinct-vertex index (mcpt/shapes/geometry.py
    shared_vertices), and the distinct edges with each triangle's signed edge indices
    (shared_edges, issue #23), padded to the shader's fixed 3 x TRI_CONST_MAX entries. Data, not
    feature switches: their names are not MCPT_ defines (those are numbers, :meth:`Features.defines`)."""
    n = 3 * TRI_CONST_MAX
    if len(vert_addr) > n or len(tri_vert_ids) > n:
        raise ValueError(f"at most {TRI_CONST_MAX} triangles have their vertex tables compiled in")
    edges, signed = shared_edges(np.asarray(tri_vert_ids, np.int64))
    pad = lambda vals: ",".join(map(str, list(vals) + [0] * (n - len(vals))))  # noqa: E731
    pad_u = lambda bits: ",".join(f"{b}u" for b in list(bits) + [0] * (3 * n - len(bits)))  # noqa: E731
    return "\n".join((f"#define TRI_VERT_ADDR_TABLE {pad(vert_addr)}",
                      f"#define TRI_VERT_IDS_TABLE {pad(tri_vert_ids)}",
                      f"#define TRI_EDGE_COUNT {len(edges)}",
                      f"#define TRI_EDGE_A_TABLE {pad(edges[:, 0])}",
                      f"#define TRI_EDGE_B_TABLE {pad(edges[:, 1])}",
                      f"#define TRI_EDGE_IDS_TABLE {pad(signed.ravel())}")
                     + ((f"#define TRI_VERT_POS_TABLE {pad_u(vert_pos)}",) if vert_pos else ()))

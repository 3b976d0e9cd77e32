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
    """The written-out brute force of glsl/bvh.glsl ``trace_const`` (small scenes), as code: each
    distinct vertex loaded and sheared once per ray (mcpt/shapes/geometry.py shared_vertices; its
    float32 bits compiled in when ``vert_pos`` gives them, else its u_tris texel), each distinct
    edge function once (shared_edges, issue #23), then each triangle's test on its signed edges
    and sheared depths, in triangle order. Generated here, not looked up in constant arrays by
    macros in the shader: Mesa's GLSL compiler spent ~1 s a program folding those lookups (the
    Cornell box's cold compile 1.9 s against 0.9 s before the positions and edges were compiled
    in). Data, not feature switches: their names are not MCPT_ defines (:meth:`Features.defines`)."""
    ids = np.asarray(tri_vert_ids, np.int64).reshape(-1, 3)
    if len(ids) > TRI_CONST_MAX or len(vert_addr) > 3 * TRI_CONST_MAX:
        raise ValueError(f"at most {TRI_CONST_MAX} triangles have their vertex tables compiled in")
    edges, signed = shared_edges(ids)
    bits = np.asarray(vert_pos, np.uint32).reshape(-1, 3) if len(vert_pos) else None
    src = [f"uintBitsToFloat(uvec3({x}u, {y}u, {z}u))" for x, y, z in bits] if bits is not None \
        else [f"uintBitsToFloat(texelFetch(u_tris, {int(a)}).xyz)" for a in vert_addr]
    ref = lambda c: f"te[{c}]" if c >= 0 else f"-te[{~c}]"  # noqa: E731 (~c: the edge reversed)
    neg = lambda c: f"tn[{c}]" if c >= 0 else f"tp[{~c}]"  # noqa: E731 (its sign tests, once per edge)
    pos = lambda c: f"tp[{c}]" if c >= 0 else f"tn[{~c}]"  # noqa: E731
    return "\n".join((
        f"#define TRI_VERT_FETCHES {0 if bits is not None else len(vert_addr)}",
        f"#define TRI_EDGE_COUNT {max(1, len(edges))}",
        "#define TRI_CONST_VERTS " + " ".join(f"tv[{k}] = tri_shear(r, p, {v});" for k, v in enumerate(src)),
        "#define TRI_CONST_EDGES " + " ".join(
            f"te[{k}] = edge_fn(tv[{a}], tv[{b}]); tn[{k}] = te[{k}] < 0.0; tp[{k}] = te[{k}] > 0.0;"
            for k, (a, b) in enumerate(edges)),
        "#define TRI_CONST_TESTS " + " ".join(
            f"TRI_CONST_TEST({i}, {ref(u)}, {ref(v)}, {ref(w)}, tv[{a}].z, tv[{b}].z, tv[{c}].z, "
            f"({neg(u)} || {neg(v)} || {neg(w)}) && ({pos(u)} || {pos(v)} || {pos(w)}))"
            for i, ((u, v, w), (a, b, c)) in enumerate(zip(signed.tolist(), ids.tolist())))))

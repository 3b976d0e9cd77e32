// Shared constants and small helpers.
const float PI = 3.14159265358979323846;
const float INV_PI = 0.31830988618379067154;
const float INF = 1.0 / 0.0;

struct Ray { vec3 o; vec3 d; };

// llvmpipe's loop limiter stops the loops of a shader invocation once they have run 65535
// iterations in total, silently (issue #6 stability suite), and the compiler has already folded
// away any "did the loop end normally" test. So where the renderer is llvmpipe, MCPT_LOOP_LIMIT
// is 65535 and every loop of the path tracer ticks a counter. A draw stops following a path at a
// quarter of the limit and a later draw continues it (MCPT_CONTINUE, glsl/path_state.glsl), so
// the limit does not cap path length; a sample whose counter still reaches 3/4 of the limit (one
// bounce that took half of it, or continuation switched off) is dropped and counted like a
// non-finite one (glsl/pathtrace.frag main). The limiter counts per SIMD batch, so a lane cut
// short early by slower neighbours can still slip through: the check catches the common case.
// 0 (real GPUs, no limiter): no counter, no cost.
#ifndef MCPT_LOOP_LIMIT
#define MCPT_LOOP_LIMIT 0
#endif
#if MCPT_LOOP_LIMIT
int g_loop_iterations = 0;
#define LOOP_TICK() (++g_loop_iterations)
// A lane sees ~80 % of its SIMD batch's iterations (measured: 53000 of 65535 on paths cut
// short), so 3/4 of the limit marks a sample as (probably) cut short.
bool loop_limit_reached() { return g_loop_iterations >= MCPT_LOOP_LIMIT / 4 * 3; }
#else
#define LOOP_TICK()
bool loop_limit_reached() { return false; }
#endif

// True for +-Inf and NaN. A bit test, because llvmpipe compiles with fast-math and may fold
// isnan()/isinf() to false (measured: ../shared/research/anchors-reliability.md).
bool non_finite(float x) { return (floatBitsToUint(x) & 0x7f800000u) == 0x7f800000u; }
bool non_finite(vec3 v) { return non_finite(v.x) || non_finite(v.y) || non_finite(v.z); }

float luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

// Offset a ray origin off a surface, scaled to the position's magnitude in float ulps rather
// than by a fixed epsilon (Waechter & Binder, "A Fast and Robust Method for Avoiding
// Self-Intersection", Ray Tracing Gems ch. 6). Integer arithmetic on the bits is immune to
// fast-math reassociation.
//
// The method's two constants for coordinates near zero (ORIGIN, FLOAT_SCALE) are absolute and
// tuned for scenes of unit size: in a Cornell box scaled by 1e-4 every coordinate is "near zero"
// and the fixed 1.5e-5 offset (7 % of the box) pushed ceiling points below the light, which then lit
// the ceiling (issue #6, case cornell-scale-0.0001: +8 % energy). Here they are taken relative to the
// point's largest coordinate m, which makes the offset scale-invariant; m ~ 1 gives the original.
vec3 offset_ray(vec3 p, vec3 n) {
    const float INT_SCALE = 256.0;
    float m = max(max(abs(p.x), abs(p.y)), abs(p.z));
    float ORIGIN = m * (1.0 / 32.0);
    float FLOAT_SCALE = m * (1.0 / 65536.0);
    ivec3 of_i = ivec3(INT_SCALE * n);
    vec3 p_i = vec3(
        intBitsToFloat(floatBitsToInt(p.x) + (p.x < 0.0 ? -of_i.x : of_i.x)),
        intBitsToFloat(floatBitsToInt(p.y) + (p.y < 0.0 ? -of_i.y : of_i.y)),
        intBitsToFloat(floatBitsToInt(p.z) + (p.z < 0.0 ? -of_i.z : of_i.z)));
    return vec3(abs(p.x) < ORIGIN ? p.x + FLOAT_SCALE * n.x : p_i.x,
                abs(p.y) < ORIGIN ? p.y + FLOAT_SCALE * n.y : p_i.y,
                abs(p.z) < ORIGIN ? p.z + FLOAT_SCALE * n.z : p_i.z);
}

// A point p of the octahedral square [-1, 1]^2 unfolded onto the octahedron (Cigolle et al. 2014,
// "A Survey of Efficient Representations for Independent Unit Vectors"): a direction, not unit
// (callers normalise). Shading normals and tangents (normals.glsl) and sphere hits (sphere.glsl).
vec3 oct_unfold(vec2 p) {
    vec3 n = vec3(p, 1.0 - abs(p.x) - abs(p.y));
    float t = max(-n.z, 0.0);
    n.x += n.x >= 0.0 ? -t : t;
    n.y += n.y >= 0.0 ? -t : t;
    return n;
}

// Orthonormal basis around a unit normal (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
void onb(vec3 n, out vec3 t, out vec3 b) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
    b = vec3(c, s + n.y * n.y * a, -n.y);
}

// Tangent-space normal maps (host side: mcpt/shading/normal_map.py, which documents the buffers
// and the tangents), and bump maps (glsl/bump_map.glsl), which share its buffers and its rules.
// Compiled only with MCPT_NORMAL_MAPS; normal_map_shadow and normal_map_apply always.
#include "geometry.glsl"
#include "normals.glsl"
#include "texture.glsl"
#include "bump_map.glsl"

#if MCPT_NORMAL_MAPS || MCPT_OPACITY
layout(binding = 13) uniform usamplerBuffer u_normal_maps;  // 1 texel per material (+ opacity)
#endif

#if MCPT_NORMAL_MAPS
layout(binding = 12) uniform usamplerBuffer u_tangents;     // 1 texel per triangle (BVH order)

// The tangent frame's T and handedness at hit h: corner tangents interpolated (a corner without
// one adds nothing), the sign of the interpolated handedness.
vec3 tri_tangent(int tri, vec2 bary, out float hand) {
    uvec4 q = texelFetch(u_tangents, tri);
    vec3 w = vec3(1.0 - bary.x - bary.y, bary.x, bary.y);
    vec3 none = vec3(uvec3(q.w >> 3, q.w >> 4, q.w >> 5) & 1u);
    vec3 neg = vec3(uvec3(q.w, q.w >> 1, q.w >> 2) & 1u);
    w *= 1.0 - none;
    hand = dot(w, 1.0 - 2.0 * neg) < 0.0 ? -1.0 : 1.0;
    return w.x * normalize(oct_decode(q.x)) + w.y * normalize(oct_decode(q.y)) + w.z * normalize(oct_decode(q.z));
}

// Any unit vector perpendicular to unit n (Duff et al. 2017, "Building an Orthonormal Basis").
vec3 any_tangent(vec3 n) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    return vec3(1.0 + s * n.x * n.x * a, s * n.x * n.y * a, -s * n.x);
}

// The front side's mapped normal of a normal map (texture `tex`, x / y times `scale`; `right`:
// B = N x T, Mitsuba's frame) at hit h on a surface of front-side shading normal nf.
vec3 mapped_normal(int tex, float scale, bool right, Hit h, vec3 nf) {
    float hand;
    vec3 t = tri_tangent(h.tri, h.bary, hand);
    t -= nf * dot(nf, t);
    t = dot(t, t) > 1e-12 ? normalize(t) : any_tangent(nf);
    vec3 b = (right ? 1.0 : hand) * cross(nf, t);
    vec3 c = (texture_rgb(tex, tri_uv(h.tri, h.bary)) * 2.0 - 1.0) * vec3(scale, scale, 1.0);
    return normalize(c.x * t + c.y * b + c.z * nf);
}
#endif

// The bump-terminator shadowing of the vertex normal_map_apply last mapped (Conty Estevez et al.
// 2019, "A Microfacet-Based Shadowing Function to Solve the Bump Terminator Problem", Ray Tracing
// Gems ch. 12): alpha^2 = min(tan^2(ns, nb) / 8, 1) of the mapped normal ns against the unmapped
// nb, and G(wi) = 2 / (1 + sqrt(1 + alpha^2 tan^2(wi, nb))) on the light / sampled direction wi.
// Mitsuba 3.9.1's normalmap multiplies its BSDF values and sample weights by it (measured: 0.9903
// at cos(wi, nb) = 0.8 and 0.9706 at 0.6 for a normal tilted to cos 0.8; exactly this G).
#if MCPT_NORMAL_MAPS
float nm_alpha2 = 0.0;   // 0: no map at this vertex (G = 1)
vec3 nm_base = vec3(0.0);
#endif

float normal_map_shadow(vec3 wi) {
#if MCPT_NORMAL_MAPS
    float c = abs(dot(wi, nm_base));
    float tan2 = max(1.0 - c * c, 0.0) / max(c * c, 1e-12);
    return 2.0 / (1.0 + sqrt(1.0 + nm_alpha2 * tan2));
#else
    return 1.0;
#endif
}

// The normal-mapped shading normal at hit h (of its triangle's material; ns: the shading normal turned
// to wo's side, front: the ray hit the geometric front side). The frame is built on the front
// side's normal and the mapped normal mirrored with it on the back, as Mitsuba's twosided does
// (it flips the local z). Where the mapped normal faces away from wo, its tangential part is
// negated (rotated half a turn about ns): what Mitsuba 3.9.1's normalmap does there (measured:
// its BSDF's lobe follows the map's normal, or that rotation of it once wo is below it). False:
// even then it faces away from wo; Mitsuba's BSDFs reflect nothing (cos_theta_i <= 0), the
// path ends.
bool normal_map_apply(Hit h, bool front, vec3 wo, inout vec3 ns) {
#if MCPT_NORMAL_MAPS
    nm_alpha2 = 0.0;
    uvec4 r = texelFetch(u_normal_maps, tri_material(h.tri));
    if (r.x == 0xffffffffu) return true;
    vec3 nf = front ? ns : -ns;
    float scale = uintBitsToFloat(r.z);
    vec3 n = (r.y & 2u) != 0u ? bump_normal(int(r.x), scale, h, nf)
                              : mapped_normal(int(r.x), scale, (r.y & 1u) != 0u, h, nf);
    n = front ? n : n - 2.0 * dot(n, nf) * nf;
    if (dot(n, wo) <= 0.0) n = 2.0 * dot(n, ns) * ns - n;
    float cn = dot(n, ns);
    nm_alpha2 = min(0.125 * max(1.0 - cn * cn, 0.0) / max(cn * cn, 1e-12), 1.0);
    nm_base = ns;
    ns = n;
    return dot(ns, wo) > 0.0;
#else
    return true;
#endif
}

// The state of a path between bounces, and (MCPT_CONTINUE) its trip through images from one draw
// to the next (host side: mcpt/gpu/path_state.py).
//
// llvmpipe stops a shader invocation's loops after 65535 iterations in total (glsl/common.glsl),
// which used to cap path length: a 1000-bounce path in the albedo-0.999 furnace was cut (and its
// sample dropped) about half the time. With MCPT_CONTINUE a draw follows each path only until its
// loop counter reaches SEGMENT_TICKS (a quarter of the limit, so a SIMD batch, which counts
// up to ~1.25x its busiest lane, stays far below it), stores the path here and counts it; the
// host then draws again over the image, and each draw continues the stored paths until none is
// left. A path needs one draw per ~SEGMENT_TICKS iterations: 8-bounce scenes never need a
// second one. Radiance is added to the accumulation target as it is gathered, so a sample's
// draws add up to its value (main() in glsl/pathtrace.frag).
#include "materials.glsl"

struct Path {
    Ray ray;              // the next ray to trace; the hit it finds is hit k
    vec3 beta;            // throughput
    vec3 L;               // radiance gathered so far (by all draws)
    int k;                // bounce convention: glsl/pathtrace.frag
    float pdf_bsdf_prev;  // solid-angle pdf of the BSDF sample that made ray (MIS)
    bool delta_prev;      // ray came from a specular lobe (or the camera)
    float eta_scale;      // product of eta^2 crossed (roulette, pbrt-v4)
    bool aov_open;        // MCPT_AOV: the sample has not added its AOVs yet (glsl/aov.glsl)
};

Path camera_path(Ray r) { return Path(r, vec3(1.0), vec3(0.0), 1, 0.0, true, 1.0, true); }

// Continuation after bsdf_sample s at hit k = P.k, at point x (ng: the geometric normal on the
// side the path came from, xo: x offset to that side): the throughput takes the sample's weight,
// the MIS memory its pdf and delta flag, roulette's its eta^2, and the next ray leaves on the
// side s goes to. Roulette (glsl/roulette.glsl) may still end the path.
void path_scatter(inout Path P, BsdfSample s, vec3 x, vec3 ng, vec3 xo) {
    P.beta *= s.weight;
    P.pdf_bsdf_prev = s.pdf;
#if MCPT_DELTA
    P.delta_prev = s.delta;
#endif
#if MCPT_TRANSMISSION && MCPT_RR
    P.eta_scale *= s.eta2;
#endif
#if MCPT_TRANSMISSION
    if (s.transmit) xo = offset_ray(x, -ng);
#endif
    P.ray = Ray(xo, s.wi);
    P.k = P.k + 1;
}

#if MCPT_CONTINUE || MCPT_WAVE
// A path between draws (MCPT_CONTINUE) or between the wavefront's kernels (glsl/wavefront.glsl):
// one texel per pixel each (RGBA32F, bound as images 0-3; w of state 0 is k, 0 = no path).
layout(binding = 0, rgba32f) uniform image2D u_state0;  // ray.o, k
layout(binding = 1, rgba32f) uniform image2D u_state1;  // ray.d, pdf_bsdf_prev
layout(binding = 2, rgba32f) uniform image2D u_state2;  // beta, eta_scale
layout(binding = 3, rgba32f) uniform image2D u_state3;  // L, 4 * sample j of the draw + 2 * aov_open + delta_prev

Path path_load(ivec2 px, out int j) {
    vec4 s0 = imageLoad(u_state0, px), s1 = imageLoad(u_state1, px);
    vec4 s2 = imageLoad(u_state2, px), s3 = imageLoad(u_state3, px);
    int w = int(s3.w);
    j = w >> 2;
    return Path(Ray(s0.xyz, s1.xyz), s2.xyz, s3.xyz, int(s0.w), s1.w, (w & 1) != 0, s2.w, (w & 2) != 0);
}

void path_write(ivec2 px, Path P, int j) {
    imageStore(u_state0, px, vec4(P.ray.o, float(P.k)));
    imageStore(u_state1, px, vec4(P.ray.d, P.pdf_bsdf_prev));
    imageStore(u_state2, px, vec4(P.beta, P.eta_scale));
    imageStore(u_state3, px, vec4(P.L, float(4 * j + (P.aov_open ? 2 : 0) + (P.delta_prev ? 1 : 0))));
}
#endif

#if MCPT_CONTINUE
#define SEGMENT_TICKS (MCPT_LOOP_LIMIT / 4)
bool segment_spent() { return g_loop_iterations >= SEGMENT_TICKS; }

layout(std430, binding = 0) buffer PathCount { uint n_unfinished; };  // reset by the host
uniform int u_continue;  // 0: start camera paths; 1: continue the stored ones

bool path_stored(ivec2 px) { return imageLoad(u_state0, px).w != 0.0; }

void path_store(ivec2 px, Path P, int j) {
    path_write(px, P, j);
    atomicAdd(n_unfinished, 1u);
}

void path_clear(ivec2 px) { imageStore(u_state0, px, vec4(0.0)); }
#endif

// The path tracer: u_samples samples per pixel per draw, added into a float32 accumulation
// target. Output: rgb = the samples' radiance (main's Tally), a = how many were dropped
// (non-finite or cut short), so the alpha channel of the accumulation counts dropped samples.
#include "common.glsl"
#include "sampler.glsl"
#include "bvh.glsl"
#include "materials.glsl"
#include "normals.glsl"
#include "texture.glsl"
#include "specular_weights.glsl"
#include "normal_map.glsl"
#include "camera.glsl"
#include "path_state.glsl"
#include "lights.glsl"
#include "roulette.glsl"
#if MCPT_MEDIUM
// issue #25: the scene's participating medium
#include "medium_scatter.glsl"
#endif
#if MCPT_AOV
#include "aov.glsl"
#endif
#if MCPT_ROUGHNESS_TEXTURES
#include "roughness_texture.glsl"
#endif

uniform ivec4 u_tile;    // x0, y0 (rows from the top), width, height of the tile being rendered
#if MCPT_CLAMP
uniform float u_clamp;   // biased: largest allowed sample component (off unless --clamp)
#endif

#if MCPT_COMPUTE
// The same path tracer dispatched as a compute shader (issue #23: a Hopper GPU runs fragment work
// on a few of its units, NVIDIA's H100 architecture paper; compute work on all of them). One
// invocation a pixel of the rectangle u_dispatch (x0, y0 in GL rows from the bottom, width,
// height); the outputs below are added into the accumulation targets, bound as images after the
// path-state images, with imageLoad + imageStore: the same float32 add as the fragment path's
// ONE, ONE blending, in the same order (one invocation a pixel a dispatch), so the same pixels.
#if !MCPT_WAVE  // glsl/wavefront.glsl declares its own work group
layout(local_size_x = 8, local_size_y = 8) in;
#endif
uniform ivec4 u_dispatch;
vec4 o_color;
layout(binding = 4, rgba32f) uniform image2D u_target0;
#if MCPT_VARIANCE
vec4 o_square;
layout(binding = 5, rgba32f) uniform image2D u_target1;
#endif
#if MCPT_AOV
vec4 o_aov_a, o_aov_b;
#if MCPT_VARIANCE
layout(binding = 6, rgba32f) uniform image2D u_target_aov_a;
layout(binding = 7, rgba32f) uniform image2D u_target_aov_b;
#else
layout(binding = 5, rgba32f) uniform image2D u_target_aov_a;
layout(binding = 6, rgba32f) uniform image2D u_target_aov_b;
#endif
#endif
void targets_add(ivec2 px) {
    imageStore(u_target0, px, imageLoad(u_target0, px) + o_color);
#if MCPT_VARIANCE
    imageStore(u_target1, px, imageLoad(u_target1, px) + o_square);
#endif
#if MCPT_AOV
    imageStore(u_target_aov_a, px, imageLoad(u_target_aov_a, px) + o_aov_a);
    imageStore(u_target_aov_b, px, imageLoad(u_target_aov_b, px) + o_aov_b);
#endif
}
#else
layout(location = 0) out vec4 o_color;
#if MCPT_VARIANCE
layout(location = 1) out vec4 o_square;  // per-pixel sum of squares -> variance of the mean; a: coverage
#endif
// AOVs (glsl/aov.glsl): the two targets after the beauty's (GLSL 4.30 wants literal locations).
#if MCPT_AOV && MCPT_VARIANCE
layout(location = 2) out vec4 o_aov_a;  // albedo.rgb, depth
layout(location = 3) out vec4 o_aov_b;  // normal.xyz, events
#elif MCPT_AOV
layout(location = 1) out vec4 o_aov_a;
layout(location = 2) out vec4 o_aov_b;
#endif
#endif
// Transparent film (MCPT_ALPHA): the sample in flight's camera ray left the scene. A continued
// sample had hit something (its path went on), so the flag starts false after a load too.
bool g_camera_escaped = false;

// Bounce convention (README, `--bounces`: 0 emitters only, 1 direct light only): emission seen
// at hit k ends a path with k - 1 scattering events; scattering at hit k is bounce k, allowed
// while k <= MCPT_BOUNCES.
//
// Sampling (mcpt/gpu/features.py): with MCPT_MIS, every vertex with a non-delta lobe takes one light
// sample and one BSDF sample, weighted by the power heuristic; emission found after a delta
// (specular) bounce, or by the camera ray, has weight 1. NEE-only (MCPT_NEE without MCPT_MIS)
// gives the light sample weight 1 and ignores emitters found by BSDF sampling unless the previous
// vertex was specular; BSDF-only (no MCPT_NEE) counts every emitter it hits (glsl/lights.glsl).
//
// Normals: n is the triangle's geometric normal; ng is n turned to the side the path arrived
// from, and decides ray offsets and which side a direction leaves on (a reflection must leave on
// ng's side, a refraction on the other: with shading normals this is the light-leak check). ns,
// the shading normal (interpolated vertex normals, else ng), is what the BSDF sees.
//
// One step: trace P.ray, gather what hit P.k adds and scatter (path_hit). Returns false when the
// path has ended, else P.ray is the next ray to trace, for hit P.k. Each piece lives in the file
// of its concept: a new light type or BSDF goes into its own files and the dispatches of
// lights.glsl and materials.glsl, not here.
bool path_hit(inout Path P, Ray ray, bool found, Hit h);
bool path_step(inout Path P) {
    Hit h;
    Ray ray = P.ray;
    bool found = trace_closest(ray, h);
    return path_hit(P, ray, found, h);
}

// What hit P.k (found: h, of ray = P.ray) adds, and the scattering there; the wavefront dispatch
// (glsl/wavefront.glsl) calls it with a hit traced by another kernel.
bool path_hit(inout Path P, Ray ray, bool found, Hit h) {
#if MCPT_MEDIUM
    int event = medium_event(P, found, h);  // glsl/medium_scatter.glsl
    if (event != MEDIUM_PASS) return event == MEDIUM_SCATTERED;
#endif
    if (!found) {
#if MCPT_ALPHA
        if (P.k == 1) {  // transparent film: the camera ray sees nothing, not even the sky
            g_camera_escaped = true;
            return false;
        }
#endif
#if MCPT_LIGHT_ENV || MCPT_LIGHT_SUN
        light_escaped(P, ray.d);  // lights.glsl
#endif
        return false;
    }
    int k = P.k;
    Material m = material(tri_material(h.tri));
    vec3 n = normalize(hit_normal_raw(h));
    float cos_o = dot(n, ray.d);  // < 0: the ray arrives at the front side
    material_absorb(P.beta, m, cos_o, h.t);  // Beer-Lambert, if the segment ran inside glass
    emitted_radiance(P, m, h, cos_o);        // lights.glsl
#if MCPT_AOV
    aov_hit(P, h, m, n, cos_o, -ray.d);
#endif
    if (k > MCPT_BOUNCES) return false;
    if (material_back_black(m, cos_o > 0.0)) return false;  // one-sided, seen from behind
    vec3 ng = cos_o < 0.0 ? n : -n;  // two-sided: the side the path came from
    vec3 wo = -ray.d;
    vec3 ns = shading_normal(m, h, ng, cos_o, wo);  // normals.glsl
    if (!normal_map_apply(h, cos_o < 0.0, wo, ns)) return false;  // normal_map.glsl
    m.albedo = albedo_at(m, h);                     // texture.glsl
#if MCPT_SPECULAR_WEIGHTS
    specular_weights_at(m, h);                      // specular_weights.glsl (issue #22)
#endif
#if MCPT_MAT_METALROUGH
    metalrough_at(m, h);                            // texture.glsl: glTF's metallicRoughnessTexture
#endif
#if MCPT_ROUGHNESS_TEXTURES
    roughness_at(m, h);                             // roughness_texture.glsl (issue #22), before NEE
#endif
    material_side(m, cos_o < 0.0);                  // materials.glsl
    if (material_black(m)) return false;  // pure emitter
    vec3 x = hit_point(h, ray);
    vec3 xo = offset_ray(x, ng);
    int dim = DIM_BOUNCE(k);
#if MCPT_NEE
    if (bsdf_has_smooth(m)) next_event(P, m, ns, ng, wo, xo, dim);  // lights.glsl
#endif
    BsdfSample s;
    if (!bsdf_sample(m, ns, wo, cos_o < 0.0, rand_bsdf(dim), s)) return false;
    if (!bsdf_sample_side_ok(s, ng)) return false;
    s.weight *= normal_map_shadow(s.wi);  // normal_map.glsl (1 without normal maps)
    path_scatter(P, s, x, ng, xo);  // path_state.glsl
    return roulette(P, k, dim);     // roulette.glsl
}

// The value a sample adds to the image: L, or L clamped (biased, off unless --clamp).
vec3 sample_value(vec3 L) {
#if MCPT_CLAMP
    float mx = max(L.r, max(L.g, L.b));
    if (mx > u_clamp) L *= u_clamp / mx;
#endif
    return L;
}

// Path regeneration: a draw takes u_samples samples per pixel (sample indices u_sample_index +
// j, sobol only; 1 for independent numbers), in ONE loop of bounces: a lane whose path has ended
// starts its next camera path in the same iteration. llvmpipe runs 8 lanes until the last one is
// done, so a loop per sample would leave a lane idle while its neighbours finish longer paths; the
// more samples a draw holds (mcpt/gpu/features.py samples_per_draw: up to 64, by image size), the
// less often a group waits for its slowest lane.
//
// Where the driver limits loop iterations (MCPT_CONTINUE, llvmpipe), a draw follows a pixel's
// paths only while it has iterations to spare; then the path (and j) goes to images and the
// next draw continues it (glsl/path_state.glsl, mcpt/gpu/render.py), so the limit no longer caps
// path length. Each draw adds to the accumulation target what it gathered: the values of the
// samples that ended in it, minus what earlier draws already added for the one they continued
// (telescoping, squares likewise), so a sample's draws sum to its value.
uniform int u_samples;

// What a draw adds to a pixel of the accumulation target (see above).
struct Tally {
    vec3 sum;       // values of the samples, minus what earlier draws added for them
    vec3 sum2;      // squares likewise (MCPT_VARIANCE)
    float dropped;  // samples dropped (alpha)
    float cover;    // MCPT_ALPHA: samples whose camera ray hit something (transparent film)
    vec3 before;    // what earlier draws already added for the sample in flight
};

Tally tally_start(vec3 before) { return Tally(vec3(0.0), vec3(0.0), 0.0, 0.0, before); }

// The sample in flight adds value v: its whole value, or what it has gathered so far when a
// later draw continues it.
void tally_add(inout Tally T, vec3 v) {
    T.sum += v - T.before; T.sum2 += v * v - T.before * T.before;
    T.before = vec3(0.0);
}

// n samples dropped, the one in flight among them: what earlier draws added for it is taken back.
void tally_drop(inout Tally T, float n) {
    T.sum -= T.before; T.sum2 -= T.before * T.before; T.dropped += n;
    T.before = vec3(0.0);
}

// A finished sample of value v; non-finite or cut short by llvmpipe's loop limit: dropped.
void tally_sample(inout Tally T, vec3 v) {
    if (non_finite(v) || loop_limit_reached()) {
        tally_drop(T, 1.0);
    } else {
        tally_add(T, v);
#if MCPT_ALPHA
        T.cover += g_camera_escaped ? 0.0 : 1.0;
#endif
    }
}

// What a pixel's tally adds to the accumulation targets (the AOVs are main()'s own).
void tally_out(Tally T) {
    o_color = vec4(T.sum, T.dropped);
#if MCPT_VARIANCE
    o_square = vec4(T.sum2, T.cover);
#endif
}

// The pixel at GL position frag (row 0 at the top), its index in the image and in the tile.
ivec2 frag_pixel(ivec2 frag, out int pix, out int tile_pix) {
    ivec2 pixel = ivec2(frag.x, u_resolution.y - 1 - frag.y);
    ivec2 local = pixel - u_tile.xy;
    pix = pixel.y * u_resolution.x + pixel.x;
    tile_pix = local.y * u_tile.z + local.x;
    return pixel;
}

// Sample j of the draw at this pixel: its random numbers and camera ray.
Path sample_start(ivec2 pixel, int pix, int tile_pix, int j) {
    sampler_init(pix, tile_pix, j);
    g_camera_escaped = false;
    return camera_path(camera_sample(pixel));
}

// The sample in flight is over (ended or dropped): if no vertex gave its AOVs, it adds zeros.
void sample_over(inout Path P) {
#if MCPT_AOV
    aov_end(P);
#endif
}

#if MCPT_WAVE
#include "wavefront.glsl"
#else
void main() {
#if MCPT_COMPUTE
    if (any(greaterThanEqual(ivec2(gl_GlobalInvocationID.xy), u_dispatch.zw))) return;
    ivec2 frag = u_dispatch.xy + ivec2(gl_GlobalInvocationID.xy);
#define DISCARD return
#else
    ivec2 frag = ivec2(gl_FragCoord.xy);
#define DISCARD discard
#endif
    int pix, tile_pix;
    ivec2 pixel = frag_pixel(frag, pix, tile_pix);
    Path P;
    int j = 0;
#if MCPT_CONTINUE
    if (u_continue != 0) {
        if (!path_stored(frag)) DISCARD;  // finished in an earlier draw
        P = path_load(frag, j);
        sampler_init(pix, tile_pix, j);
    } else {
        P = sample_start(pixel, pix, tile_pix, 0);
    }
#else
    P = sample_start(pixel, pix, tile_pix, 0);
#endif
    Tally T = tally_start(sample_value(P.L));  // what earlier draws added for this sample
    bool unfinished = false;
    for (;;) {
        LOOP_TICK();
#if MCPT_CONTINUE
        if (segment_spent()) { unfinished = true; break; }
#endif
        if (path_step(P)) continue;
        sample_over(P);
        tally_sample(T, sample_value(P.L));
        if (++j >= u_samples) break;
        P = sample_start(pixel, pix, tile_pix, j);
    }
    // llvmpipe's limiter ended the loop itself (a bounce took more than the rest of the budget,
    // or MCPT_CONTINUE is off): the sample in flight and those not started are dropped, counted.
    // (The compiler knows how the loop's breaks leave j, so the counter, not j, tells.)
    if (!unfinished && loop_limit_reached()) {
        sample_over(P);
        tally_drop(T, float(u_samples - j));
    }
    if (unfinished) {
        vec3 v = sample_value(P.L);
        if (non_finite(v)) {  // not worth continuing: dropped now
            sample_over(P);
            tally_drop(T, 1.0);
            unfinished = ++j < u_samples;
            if (unfinished) P = sample_start(pixel, pix, tile_pix, j);
        } else {
            tally_add(T, v);
        }
    }
#if MCPT_CONTINUE
    if (unfinished) path_store(frag, P, j);
    else if (u_continue != 0) path_clear(frag);
#endif
    tally_out(T);
#if MCPT_AOV
    o_aov_a = g_aov_a;
    o_aov_b = g_aov_b;
#endif
#if MCPT_COMPUTE
    targets_add(frag);
#endif
}
#endif  // MCPT_WAVE

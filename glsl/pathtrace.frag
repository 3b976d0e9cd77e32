// The path tracer: one sample per pixel per pass, added into a float32 accumulation target.
// Output: rgb = radiance estimate, a = 1 when the sample was non-finite and dropped (so the
// alpha channel of the accumulation counts dropped samples per pixel).
#include "common.glsl"
#include "sampler.glsl"
#include "bvh.glsl"
#include "materials.glsl"
#include "camera.glsl"
#include "path_state.glsl"
#if MCPT_NEE
#include "lights.glsl"
#endif
#if MCPT_SMOOTH_NORMALS
#include "normals.glsl"
#endif
#if MCPT_TEXTURES
#include "texture.glsl"
#endif
#if MCPT_AOV
#include "aov.glsl"
#endif

uniform ivec4 u_tile;    // x0, y0 (rows from the top), width, height of the tile being rendered
#if MCPT_CLAMP
uniform float u_clamp;   // biased: largest allowed sample component (off unless --clamp)
#endif

layout(location = 0) out vec4 o_color;
#if MCPT_VARIANCE
layout(location = 1) out vec4 o_square;  // per-pixel sum of squares -> variance of the mean
#endif
// AOVs (glsl/aov.glsl): the two targets after the beauty's (GLSL 4.30 wants literal locations).
#if MCPT_AOV && MCPT_VARIANCE
layout(location = 2) out vec4 o_aov_a;  // albedo.rgb, depth
layout(location = 3) out vec4 o_aov_b;  // normal.xyz, events
#elif MCPT_AOV
layout(location = 1) out vec4 o_aov_a;
layout(location = 2) out vec4 o_aov_b;
#endif

// Power heuristic with beta = 2 (Veach 1997, sec. 9.2.4).
float power_heuristic(float a, float b) {
    float a2 = a * a, b2 = b * b;
    return a2 / (a2 + b2);
}

// Bounce convention (scene.json): emission seen at hit k ends a path with k - 1 scattering
// events; scattering at hit k is bounce k, allowed while k <= MCPT_BOUNCES.
//
// Sampling (mcpt/gpu/features.py): with MCPT_MIS, every vertex with a non-delta lobe takes one light
// sample and one BSDF sample, weighted by the power heuristic; emission found after a delta
// (specular) bounce, or by the camera ray, has weight 1. NEE-only (MCPT_NEE without MCPT_MIS)
// gives the light sample weight 1 and ignores emitters found by BSDF sampling unless the previous
// vertex was specular; BSDF-only (no MCPT_NEE) counts every emitter it hits.
//
// Normals: n is the triangle's geometric normal; ng is n turned to the side the path arrived
// from, and decides ray offsets and which side a direction leaves on (a reflection must leave on
// ng's side, a refraction on the other: with shading normals this is the light-leak check). ns,
// the shading normal (interpolated vertex normals, else ng), is what the BSDF sees.
//
// One step: trace P.ray, gather what hit P.k adds and scatter. Returns false when the path has
// ended, else P.ray is the next ray to trace, for hit P.k.
bool path_step(inout Path P) {
    {
        Hit h;
        Ray ray = P.ray;
        if (!trace_closest(ray, h)) return false;
        int k = P.k;
        Material m = material(tri_material(h.tri));
        vec3 n = normalize(tri_normal_raw(h.tri));
        float cos_o = dot(n, ray.d);  // < 0: the ray arrives at the front side
#if MCPT_ABSORPTION
        // Arriving at a dielectric's back side: the last segment ran inside it (Beer-Lambert).
        if (m.type == MAT_DIELECTRIC && cos_o > 0.0) P.beta *= exp(-m.sigma_a * h.t);
#endif
        if (cos_o < 0.0 && max(m.emission.r, max(m.emission.g, m.emission.b)) > 0.0) {
            float w = 1.0;
#if MCPT_NEE
  #if MCPT_DELTA
            if (!P.delta_prev) {
  #else
            if (k > 1) {
  #endif
  #if MCPT_MIS
                // Density with which NEE would have produced this point, as a solid angle.
                float pdf_light = m.light_pdf_area * h.t * h.t / -cos_o;
                w = power_heuristic(P.pdf_bsdf_prev, pdf_light);
  #else
                w = 0.0;  // NEE-only: light is found by light sampling alone
  #endif
            }
#endif
            P.L += P.beta * m.emission * w;
        }
#if MCPT_AOV
        aov_hit(P, h, m, n, cos_o, -ray.d);
#endif
        if (k > MCPT_BOUNCES) return false;
        if (material_back_black(m, cos_o > 0.0)) return false;  // one-sided, seen from behind
        vec3 ng = cos_o < 0.0 ? n : -n;  // two-sided: the side the path came from
        vec3 ns = ng;
        vec3 wo = -ray.d;
#if MCPT_SMOOTH_NORMALS
        if ((m.flags & MAT_FLAG_SMOOTH) != 0u) {
            vec3 sn = normalize(shading_normal_raw(h.tri, h.bary));
            sn = cos_o < 0.0 ? sn : -sn;
            // Where the interpolated normal faces away from wo (silhouettes of coarse meshes) or
            // is undefined, shade with the geometric normal.
            if (dot(sn, wo) > 0.0) ns = sn;
        }
#endif
#if MCPT_TEXTURES
        if (m.texture >= 0) m.albedo = texture_rgb(m.texture, tri_uv(h.tri, h.bary));
#endif
        if (material_black(m)) return false;  // pure emitter
        vec3 x = tri_point(h.tri, h.bary);
        vec3 xo = offset_ray(x, ng);
        int dim = DIM_BOUNCE(k);
#if MCPT_NEE
        if (bsdf_has_smooth(m)) {
            float pmf;
            int lt = light_pick(rand_at(dim + DIM_LIGHT_PICK), pmf);
            vec2 bb = sample_triangle_bary(rand2_at(dim + DIM_LIGHT_UV));
            vec3 y = tri_point(lt, bb);
            vec3 nl = tri_normal_raw(lt);
            float area2 = length(nl);  // twice the area
            nl /= area2;
            vec3 dv = y - xo;
            float d2 = dot(dv, dv);
            float dist = sqrt(d2);
            vec3 wi = dv / dist;
            float cos_l = -dot(nl, wi);
            float pdf_b;
            vec3 fc = bsdf_eval(m, ns, wo, wi, pdf_b);
  #if MCPT_SMOOTH_NORMALS
            if (dot(ng, wi) <= 0.0) fc = vec3(0.0);  // below the real surface: no light leaks in
  #endif
            if (cos_l > 0.0 && max(fc.r, max(fc.g, fc.b)) > 0.0) {
                float pdf_light = pmf * (2.0 / area2) * d2 / cos_l;
                vec3 yo = offset_ray(y, nl);
                vec3 seg = yo - xo;
                float seg_len = length(seg);
                if (visible(Ray(xo, seg / seg_len), seg_len)) {
                    float w = 1.0;
  #if MCPT_MIS
                    w = power_heuristic(pdf_light, pdf_b);
  #endif
                    P.L += P.beta * fc * material(tri_material(lt)).emission * (w / pdf_light);
                }
            }
        }
#endif
        BsdfSample s;
        if (!bsdf_sample(m, ns, wo, cos_o < 0.0, rand2_at(dim + DIM_BSDF_UV), s)) return false;
#if MCPT_SMOOTH_NORMALS || MCPT_MAT_DIELECTRIC
        // A reflection must leave on ng's side and a refraction on the other (see above).
        if ((dot(s.wi, ng) > 0.0) == s.transmit) return false;
#endif
        P.beta *= s.weight;
        P.pdf_bsdf_prev = s.pdf;
#if MCPT_DELTA
        P.delta_prev = s.delta;
#endif
#if MCPT_MAT_DIELECTRIC && MCPT_RR
        P.eta_scale *= s.eta2;
#endif
#if MCPT_RR
        // Russian roulette on the throughput (unbiased: survivors are divided by q). Radiance
        // inside glass is scaled by 1/eta^2, which says nothing about the path's future: undone.
        if (k >= MCPT_RR_START) {
  #if MCPT_MAT_DIELECTRIC
            vec3 rb = P.beta * P.eta_scale;
  #else
            vec3 rb = P.beta;
  #endif
            // pbrt-v4's rule: only a path whose (eta-corrected) throughput fell below 1 plays,
            // and it survives with exactly that probability, with no cap below 1. A cap (we had
            // 0.95, as Mitsuba 3) makes survivors' weights grow by albedo/cap per bounce, a
            // heavy-tailed estimate that at albedo 0.999 practically never reaches its mean
            // (issue #10: furnace at 1000 bounces gave 221 for 632.67).
            float q = max(rb.r, max(rb.g, rb.b));
            if (q < 1.0) {
                if (rand_at(dim + DIM_RR) >= q) return false;
                P.beta /= q;
            }
        }
#endif
#if MCPT_MAT_DIELECTRIC
        if (s.transmit) xo = offset_ray(x, -ng);
#endif
        P.ray = Ray(xo, s.wi);
        P.k = k + 1;
    }
    return true;
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

void main() {
    ivec2 frag = ivec2(gl_FragCoord.xy);
    ivec2 pixel = ivec2(frag.x, u_resolution.y - 1 - frag.y);  // row 0 at the top
    ivec2 local = pixel - u_tile.xy;
    int pix = pixel.y * u_resolution.x + pixel.x, tile_pix = local.y * u_tile.z + local.x;
    Path P;
    int j = 0;
#if MCPT_CONTINUE
    if (u_continue != 0) {
        if (!path_stored(frag)) discard;  // finished in an earlier draw
        P = path_load(frag, j);
        sampler_init(pix, tile_pix, j);
    } else
#endif
    {
        sampler_init(pix, tile_pix, 0);
        P = camera_path(camera_ray(pixel, rand2_at(DIM_CAMERA)));
    }
    vec3 before = sample_value(P.L);  // what earlier draws added for this sample
    vec3 sum = vec3(0.0), sum2 = vec3(0.0);
    float dropped = 0.0;
    bool unfinished = false;
    for (;;) {
        LOOP_TICK();
#if MCPT_CONTINUE
        if (segment_spent()) { unfinished = true; break; }
#endif
        if (path_step(P)) continue;
#if MCPT_AOV
        aov_end(P);
#endif
        vec3 v = sample_value(P.L);
        // Non-finite or cut short by llvmpipe's loop limit: dropped (what earlier draws added
        // for it is taken back) and counted in alpha.
        if (non_finite(v) || loop_limit_reached()) {
            sum -= before; sum2 -= before * before; dropped += 1.0;
        } else {
            sum += v - before; sum2 += v * v - before * before;
        }
        before = vec3(0.0);
        if (++j >= u_samples) break;
        sampler_init(pix, tile_pix, j);
        P = camera_path(camera_ray(pixel, rand2_at(DIM_CAMERA)));
    }
    // llvmpipe's limiter ended the loop itself (a bounce took more than the rest of the budget,
    // or MCPT_CONTINUE is off): the sample in flight and those not started are dropped, counted.
    // (The compiler knows how the loop's breaks leave j, so the counter, not j, tells.)
    if (!unfinished && loop_limit_reached()) {
#if MCPT_AOV
        aov_end(P);
#endif
        sum -= before; sum2 -= before * before;
        dropped += float(u_samples - j);
        before = vec3(0.0);
    }
    if (unfinished) {
        vec3 v = sample_value(P.L);
        if (non_finite(v)) {  // not worth continuing: dropped now
#if MCPT_AOV
            aov_end(P);
#endif
            sum -= before; sum2 -= before * before; dropped += 1.0;
            unfinished = ++j < u_samples;
            if (unfinished) {
                sampler_init(pix, tile_pix, j);
                P = camera_path(camera_ray(pixel, rand2_at(DIM_CAMERA)));
            }
        } else {
            sum += v - before; sum2 += v * v - before * before;
        }
    }
#if MCPT_CONTINUE
    if (unfinished) path_store(frag, P, j);
    else if (u_continue != 0) path_clear(frag);
#endif
    o_color = vec4(sum, dropped);
#if MCPT_VARIANCE
    o_square = vec4(sum2, 0.0);
#endif
#if MCPT_AOV
    o_aov_a = g_aov_a;
    o_aov_b = g_aov_b;
#endif
}

// Arbitrary output variables (AOVs) for compositors and denoisers (host side: mcpt/gpu/aov.py).
// Compiled in only with MCPT_AOV (--aov albedo/normal/depth, --denoise).
//
// Each sample adds, exactly once, an "AOV event" into two extra render targets summed like the
// beauty (additive blending, read back with it on the pass grid):
//   target A: albedo.rgb, depth        target B: normal.xyz, count (1 per event)
// Albedo and normal are those of the first NON-SPECULAR vertex: mirror and glass (delta) bounces
// are followed to it, as Intel Open Image Denoise recommends (OIDN documentation, "RT" filter:
// "for perfect specular materials ... the albedo/normal of the first diffuse or glossy hit").
// The normal is the shading normal turned to the side the path arrived from (world space: the
// scene is only translated to put the camera at the origin). A sample whose path ends before such
// a vertex (it escapes, or bounce limit / roulette / a dead end on a specular chain) adds albedo 0
// and normal 0 (camera ray escapes: all 0). Depth is the distance along the camera ray to the
// first hit, any material (0 when it escapes). The host divides by the count, so a read-back the
// renderer drops as non-finite takes its AOVs with it (mcpt/gpu/render.py drop_nonfinite); a sample
// whose radiance alone is non-finite keeps its (finite) AOVs.
#include "path_state.glsl"
#include "normals.glsl"
#include "texture.glsl"

vec4 g_aov_a = vec4(0.0);  // this draw's sums: albedo.rgb, depth [scene units]
vec4 g_aov_b = vec4(0.0);  // normal.xyz, events

void aov_event(inout Path P, vec3 albedo, vec3 normal) {
    g_aov_a.rgb += albedo;
    g_aov_b += vec4(normal, 1.0);
    P.aov_open = false;
}

// At hit k of P (before anything is scattered): depth at the camera ray's hit, albedo and normal
// at the first vertex with a non-delta lobe (bsdf_has_smooth; a pure emitter counts: albedo 0).
void aov_hit(inout Path P, Hit h, Material m, vec3 n, float cos_o, vec3 wo) {
    if (P.k == 1) g_aov_a.a += h.t;  // camera rays are unit length: t is the distance
    if (!P.aov_open || !bsdf_has_smooth(m)) return;
    vec3 ns = shading_normal(m, h, cos_o < 0.0 ? n : -n, cos_o, wo);  // as path_step
    vec3 albedo = albedo_at(m, h);
    if (material_back_black(m, cos_o > 0.0)) albedo = vec3(0.0);
    aov_event(P, clamp(albedo, 0.0, 1.0), ns);
}

// The sample is over (ended, dropped or cut): if no vertex gave its AOVs, it adds zeros.
void aov_end(inout Path P) {
    if (P.aov_open) aov_event(P, vec3(0.0), vec3(0.0));
}

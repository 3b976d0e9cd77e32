// Material table and BSDF dispatch (host side: mcpt/shading/materials.py, which documents the layout).
// MCPT_MAT_TEXELS RGBA32UI texels per material:
//   0 (albedo.rgb, type)  1 (emission.rgb, light_pdf_area)              -- always
//     (with MCPT_EMISSION_TEXTURES 1.w is the emission texture id: glsl/emission_texture.glsl)
//   2 (alpha, ior, texture id, flags)  3 (sigma_a.rgb, fdr_int)          -- when MCPT_MAT_TEXELS >= 4
//   4 (k.rgb, 0)                       -- with a complex-Fresnel conductor (MCPT_FRESNEL_COMPLEX)
//     metal-rough: (F0.rgb, F90), KHR_materials_ior / _specular -- MCPT_METALROUGH_SPECULAR
//   MCPT_SPEC_TEXEL, +1: (specular_reflectance.rgb, texture id), (specular_transmittance.rgb, texture
//     id) -- MCPT_SPECULAR_WEIGHTS (issue #22, glsl/specular_weights.glsl)
//   the last 16: a rough plastic's transmittance table (bsdf_roughplastic.glsl) -- MCPT_MAT_ROUGH_PLASTIC
// light_pdf_area = luminance(Le) / total emitted power: the density, per unit area, with which
// next-event estimation picks a point on a triangle of this material (needed for MIS).
//
// Every BSDF works with a shading normal n on the side of wo (dot(n, wo) > 0) and returns
// f * |cos| (never f alone), so a Lambertian's 1/pi and cosine cancel against its pdf in one
// place. Each material type lives in its own file, compiled only when the scene uses it.
//
// A new BSDF is one new file pair, glsl/bsdf_<name>.glsl (its <name>_sample and <name>_eval)
// beside its host twin under mcpt/shading/ (its parameters in the table; today's BSDFs share
// mcpt/shading/materials.py, whose TYPES gets its id), plus one line in each dispatch below
// (marked "Dispatch": the #include, bsdf_has_smooth, bsdf_eval, bsdf_sample).
layout(binding = 4) uniform usamplerBuffer u_materials;

#define MAT_DIFFUSE 0
#define MAT_CONDUCTOR 1
#define MAT_DIELECTRIC 2
#define MAT_PLASTIC 3
// 4: MAT_ROUGH_DIELECTRIC (bsdf_roughdielectric.glsl), 5: MAT_THIN_DIELECTRIC (bsdf_thindielectric.glsl),
// 6: MAT_ROUGH_PLASTIC (bsdf_roughplastic.glsl, whose table is the last 16 texels of its block)
// 7: MAT_METALROUGH (bsdf_metalrough.glsl: glTF's metal-rough; metallic in texel 3.x)
#define MAT_FLAG_SMOOTH 1u
#define MAT_FLAG_ONE_SIDED 8u   // bits 1-2: the conductor's Fresnel mode (bsdf_conductor.glsl)
// bits 4-5: the microfacet distribution and masking term (bsdf_microfacet.glsl)
#define MAT_FLAG_NONLINEAR 64u  // plastics: Mitsuba's nonlinear (bsdf_plastic.glsl, bsdf_roughplastic.glsl)

struct Material {
    vec3 albedo; int type; vec3 emission; float light_pdf_area;
#if MCPT_EMISSION_TEXTURES
    int emission_texture;  // texel 1.w instead of light_pdf_area: -1 none (glsl/emission_texture.glsl)
#endif
#if MCPT_MAT_TEXELS > 2
    float alpha;    // microfacet alpha (conductor, 0: mirror; rough dielectric)
    float ior;      // index of refraction (dielectrics, plastic); the outside is air
    int texture;    // albedo texture id, -1: none
    uint flags;     // MAT_FLAG_SMOOTH: shade with interpolated vertex normals
    vec3 sigma_a;   // absorption per unit length inside a dielectric
    float fdr_int;  // plastic: diffuse Fresnel reflectance of the coat seen from inside
    // Conductor, in sigma_a's texel: Schlick's lobe scale, or eta (the complex index's real part).
    vec3 scale; vec3 eta;
#endif
#if MCPT_FRESNEL_COMPLEX
    vec3 k;         // conductor, complex Fresnel: the extinction coefficient
#endif
#if MCPT_MAT_ROUGH_PLASTIC
    int base;       // the material's first texel (rough plastic reads its table after it)
#endif
#if MCPT_METALROUGH_SPECULAR
    vec3 mr_f0; float mr_f90;  // metal-rough: the dielectric's Fresnel F0, F90 (bsdf_metalrough.glsl)
#endif
#if MCPT_SPECULAR_WEIGHTS
    vec3 spec_r; int spec_r_tex;  // issue #22: Mitsuba's specular_reflectance (texture id, -1: none)
    vec3 spec_t; int spec_t_tex;  // and specular_transmittance (glass)
#endif
};

// The factors on a glass's (plastic coat's) reflected and transmitted lobes, as Mitsuba's
// specular_reflectance / specular_transmittance: constant 1 (folded away) unless some material
// has one (issue #22, mcpt/shading/specular_weights.py).
#if MCPT_SPECULAR_WEIGHTS
#define SPEC_R(m) ((m).spec_r)
#define SPEC_T(m) ((m).spec_t)
#else
#define SPEC_R(m) vec3(1.0)
#define SPEC_T(m) vec3(1.0)
#endif

Material material(int id) {
    int base = MCPT_MAT_TEXELS * id;
    uvec4 a = texelFetch(u_materials, base);
    uvec4 b = texelFetch(u_materials, base + 1);
    Material m;
    m.albedo = uintBitsToFloat(a.xyz); m.type = int(a.w);
    m.emission = uintBitsToFloat(b.xyz);
#if MCPT_EMISSION_TEXTURES
    // Texel 1.w holds the emission texture; the area density is per triangle (u_emit_pdf).
    m.emission_texture = int(b.w); m.light_pdf_area = 0.0;
#else
    m.light_pdf_area = uintBitsToFloat(b.w);
#endif
#if MCPT_MAT_TEXELS > 2
    uvec4 c = texelFetch(u_materials, base + 2);
    uvec4 d = texelFetch(u_materials, base + 3);
    m.alpha = uintBitsToFloat(c.x); m.ior = uintBitsToFloat(c.y);
    m.texture = int(c.z); m.flags = c.w;
    m.sigma_a = uintBitsToFloat(d.xyz); m.fdr_int = uintBitsToFloat(d.w);
    m.scale = m.sigma_a; m.eta = m.sigma_a;
#endif
#if MCPT_FRESNEL_COMPLEX
    m.k = uintBitsToFloat(texelFetch(u_materials, base + 4).xyz);
#endif
#if MCPT_MAT_ROUGH_PLASTIC
    m.base = base;
#endif
#if MCPT_METALROUGH_SPECULAR
    uvec4 e = texelFetch(u_materials, base + 4);
    m.mr_f0 = uintBitsToFloat(e.xyz); m.mr_f90 = uintBitsToFloat(e.w);
#endif
#if MCPT_SPECULAR_WEIGHTS
    uvec4 sr = texelFetch(u_materials, base + MCPT_SPEC_TEXEL);
    uvec4 st = texelFetch(u_materials, base + MCPT_SPEC_TEXEL + 1);
    m.spec_r = uintBitsToFloat(sr.xyz); m.spec_r_tex = int(sr.w);
    m.spec_t = uintBitsToFloat(st.xyz); m.spec_t_tex = int(st.w);
#endif
    return m;
}

float max3(vec3 v) { return max(v.r, max(v.g, v.b)); }

// What sampling a BSDF returns.
struct BsdfSample {
    vec3 wi;        // sampled direction (unit, world space)
    vec3 weight;    // f |cos| / pdf, the lobe-choice probability included
    float pdf;      // solid-angle density of wi over the non-delta lobes (MIS); 0 if delta
    bool delta;     // specular: an emitter found along wi is not MIS-weighted
    bool transmit;  // wi leaves through the other side of the surface
    float eta2;     // squared relative index crossed (1 unless refracted), for roulette
};

// Dispatch: one #include per BSDF file.
#if MCPT_MAT_DIFFUSE || MCPT_MAT_PLASTIC || MCPT_MAT_ROUGH_PLASTIC || MCPT_MAT_METALROUGH
#include "bsdf_diffuse.glsl"
#endif
#if MCPT_MICROFACET
#include "bsdf_ggx.glsl"
#if MCPT_BECKMANN
#include "bsdf_beckmann.glsl"
#endif
#include "bsdf_microfacet.glsl"
#endif
#if MCPT_MAT_DIELECTRIC || MCPT_MAT_PLASTIC || MCPT_MAT_CONDUCTOR || MCPT_MAT_ROUGH_DIELECTRIC || MCPT_MAT_THIN_DIELECTRIC || MCPT_MAT_ROUGH_PLASTIC
#include "bsdf_fresnel.glsl"
#endif
#if MCPT_MAT_CONDUCTOR
#include "bsdf_conductor.glsl"
#endif
#if MCPT_MAT_DIELECTRIC
#include "bsdf_dielectric.glsl"
#endif
#if MCPT_MAT_PLASTIC
#include "bsdf_plastic.glsl"
#endif
#if MCPT_MAT_ROUGH_DIELECTRIC
#include "bsdf_roughdielectric.glsl"
#endif
#if MCPT_MAT_THIN_DIELECTRIC
#include "bsdf_thindielectric.glsl"
#endif
#if MCPT_MAT_ROUGH_PLASTIC
#include "bsdf_roughplastic.glsl"
#endif
#if MCPT_MAT_METALROUGH
#include "bsdf_metalrough.glsl"
#endif

// The material as seen from the side the path arrives on (`front`: the outside). A rough
// dielectric's eval needs the relative index across the surface, which bsdf_eval has no side
// for: its ior becomes n (other side) / n (this side) here, once per hit.
void material_side(inout Material m, bool front) {
#if MCPT_MAT_ROUGH_DIELECTRIC
    if (m.type == MAT_ROUGH_DIELECTRIC && !front) m.ior = 1.0 / m.ior;
#endif
}

// A one-sided material (two_sided: false) seen from its back (the ray arrives at the geometric
// back side) reflects nothing, as Mitsuba 3's BSDFs do outside a `twosided` wrapper. Glass is
// two-sided by nature (the table never flags it).
bool material_back_black(Material m, bool back) {
#if MCPT_ONE_SIDED
    return back && (m.flags & MAT_FLAG_ONE_SIDED) != 0u;
#else
    return false;
#endif
}

// A surface that reflects nothing ends the path (e.g. the Cornell light, a pure emitter). Only a
// black Lambertian qualifies: a black conductor still reflects at grazing angles (Schlick), a
// black plastic still has its coat, glass is never black.
bool material_black(Material m) {
#if MCPT_MAT_DIFFUSE
    return m.type == MAT_DIFFUSE && max3(m.albedo) <= 0.0;
#else
    return false;
#endif
}

// Whether the material has a non-delta lobe, i.e. whether light sampling can find anything.
// Dispatch: one line per BSDF with a delta lobe.
bool bsdf_has_smooth(Material m) {
#if MCPT_MAT_CONDUCTOR
    if (m.type == MAT_CONDUCTOR) return m.alpha > 0.0;
#endif
#if MCPT_MAT_DIELECTRIC
    if (m.type == MAT_DIELECTRIC) return false;
#endif
#if MCPT_MAT_THIN_DIELECTRIC
    if (m.type == MAT_THIN_DIELECTRIC) return false;
#endif
    return true;
}

// f |cos| of the non-delta lobes for directions wo, wi (unit), and the solid-angle pdf with
// which bsdf_sample would produce wi. Zero when wi is below the surface (reflection only).
// Dispatch: one line per BSDF (the Lambertian, the default, last).
vec3 bsdf_eval(Material m, vec3 n, vec3 wo, vec3 wi, out float pdf) {
#if MCPT_MAT_CONDUCTOR
    if (m.type == MAT_CONDUCTOR) return conductor_eval(m, n, wo, wi, pdf);
#endif
#if MCPT_MAT_PLASTIC
    if (m.type == MAT_PLASTIC) return plastic_eval(m, n, wo, wi, pdf);
#endif
#if MCPT_MAT_ROUGH_PLASTIC
    if (m.type == MAT_ROUGH_PLASTIC) return roughplastic_eval(m, n, wo, wi, pdf);
#endif
#if MCPT_MAT_METALROUGH
    if (m.type == MAT_METALROUGH) return metalrough_eval(m, n, wo, wi, pdf);
#endif
#if MCPT_MAT_DIELECTRIC
    if (m.type == MAT_DIELECTRIC) { pdf = 0.0; return vec3(0.0); }
#endif
#if MCPT_MAT_ROUGH_DIELECTRIC
    if (m.type == MAT_ROUGH_DIELECTRIC) return roughdielectric_eval(m, n, wo, wi, false, pdf);
#endif
#if MCPT_MAT_THIN_DIELECTRIC
    if (m.type == MAT_THIN_DIELECTRIC) { pdf = 0.0; return vec3(0.0); }
#endif
#if MCPT_MAT_DIFFUSE
    pdf = diffuse_pdf(n, wi);
    return diffuse_eval(m.albedo, n, wi);
#else
    pdf = 0.0;
    return vec3(0.0);
#endif
}

// Sample wi given wo. `front`: wo is on the geometric front side (outside, for glass). u.xy: two
// uniform numbers (materials with two lobes pick the lobe with u.x and rescale it); u.z: a third
// for the rough dielectric's lobe (glsl/sampler.glsl rand_bsdf). False when the sample carries
// nothing (the path ends).
// Dispatch: one line per BSDF (the Lambertian, the default, last).
bool bsdf_sample(Material m, vec3 n, vec3 wo, bool front, vec3 u, out BsdfSample s) {
    s.delta = false; s.transmit = false; s.eta2 = 1.0;
#if MCPT_MAT_CONDUCTOR
    if (m.type == MAT_CONDUCTOR) return conductor_sample(m, n, wo, u.xy, s);
#endif
#if MCPT_MAT_DIELECTRIC
    if (m.type == MAT_DIELECTRIC) return dielectric_sample(m, n, wo, front, u.x, s);
#endif
#if MCPT_MAT_PLASTIC
    if (m.type == MAT_PLASTIC) return plastic_sample(m, n, wo, u.xy, s);
#endif
#if MCPT_MAT_ROUGH_DIELECTRIC
    if (m.type == MAT_ROUGH_DIELECTRIC) return roughdielectric_sample(m, n, wo, u, s);
#endif
#if MCPT_MAT_THIN_DIELECTRIC
    if (m.type == MAT_THIN_DIELECTRIC) return thindielectric_sample(m, n, wo, u.x, s);
#endif
#if MCPT_MAT_ROUGH_PLASTIC
    if (m.type == MAT_ROUGH_PLASTIC) return roughplastic_sample(m, n, wo, u.xy, s);
#endif
#if MCPT_MAT_METALROUGH
    if (m.type == MAT_METALROUGH) return metalrough_sample(m, n, wo, u.xy, s);
#endif
#if MCPT_MAT_DIFFUSE
    s.wi = sample_cosine(n, u.xy, s.pdf);
    s.weight = m.albedo;  // f cos / pdf for the Lambertian
    return true;
#else
    return false;
#endif
}

// A sampled direction must leave on the geometric normal ng's side when reflected and on the
// other when refracted (ng: turned to the side the path came from; with shading normals this
// is the light-leak check, glsl/pathtrace.frag "Normals"). False: the path ends.
bool bsdf_sample_side_ok(BsdfSample s, vec3 ng) {
#if MCPT_SMOOTH_NORMALS || MCPT_TRANSMISSION || MCPT_NORMAL_MAPS
    return (dot(s.wi, ng) > 0.0) != s.transmit;
#else
    return true;
#endif
}

// Beer-Lambert absorption over the segment of length t just traced, when it ran inside a
// dielectric (the ray arrives at its back side, cos_o > 0).
void material_absorb(inout vec3 beta, Material m, float cos_o, float t) {
#if MCPT_ABSORPTION
    if (m.type == MAT_DIELECTRIC && cos_o > 0.0) beta *= exp(-m.sigma_a * t);
#endif
}

// Test probe (tests/test_sampling*.py, tests/test_materials*.py): run one sampling or evaluation
// routine of the real GLSL per item and return its result as float bits, so the host can run
// chi-square and energy tests on exactly what the renderer executes. Item i reads texel i of the
// probe buffer. The material comes from uniforms; the shading normal is +z.
//   mode 0  bsdf_sample(u = p.xyz)     -> (wi.xyz, pdf); wi = 0 when the sample was rejected
//   mode 1  bsdf_sample(u = p.xyz)     -> (weight.rgb, flags: 1 valid, 2 delta, 4 transmit)
//   mode 2  bsdf_eval(wi = p.xyz)      -> (f|cos|.rgb, pdf)
//   mode 3  light_pick(u = p.x)        -> (light index, pmf, u rescaled in its bucket, 0)
//   mode 4  sample_triangle_bary(p.xy) -> (b1, b2, 0, 0)
//   mode 5  texture_rgb(p.z, uv = p.xy) -> (rgb, 0)
//   mode 6  shading_normal_raw(tri = p.x, bary = p.yz), normalised -> (n.xyz, 0)
//   mode 7  bsdf_sample(u = p.xyz)     -> (eta2, 0, 0, 0)
//   mode 8  fresnel_conductor(cos = p.x, eta = p.y, k = p.z; the same in each channel) -> (F.rgb, 0)
//   mode 9  sample_cone(u = p.xy, axis = u_wo, cos_max = u_alpha) -> (wi.xyz, 0)  (sun disks)
//   mode 10 sample_uniform_sphere(u = p.xy) -> (wi.xyz, 0)  (constant environment)
//   mode 11 roughdielectric_eval(wi = p.xyz), both lobes -> (f|cos|.rgb, pdf)
#include "common.glsl"
#include "materials.glsl"
#if MCPT_NEE
#include "lights.glsl"
#endif
#if MCPT_SMOOTH_NORMALS
#include "normals.glsl"
#endif
#if MCPT_TEXTURES
#include "texture.glsl"
#endif
layout(binding = 6) uniform usamplerBuffer u_probe;
uniform int u_width;
uniform int u_count;
uniform int u_mode;
uniform int u_type;
uniform vec3 u_albedo;
uniform float u_alpha;
uniform float u_ior;
uniform float u_fdr_int;
uniform vec3 u_wo;
uniform int u_flags;    // material flags (Fresnel mode, one-sided): mcpt/shading/materials.py
uniform vec3 u_scale;   // conductor: Schlick's lobe scale
uniform vec3 u_eta;     // conductor: complex index (fresnel: conductor)
uniform vec3 u_k;
uniform int u_front;
uniform vec3 u_mr_f0;   // metal-rough: the dielectric's F0, F90 (KHR_materials_ior / _specular)
uniform float u_mr_f90;
uniform vec3 u_spec_r;  // issue #22: specular_reflectance / specular_transmittance (default 1)
uniform vec3 u_spec_t;
layout(location = 0) out uvec4 o_out;

Material probe_material() {
    Material m;
    m.albedo = u_albedo; m.type = u_type; m.emission = vec3(0.0); m.light_pdf_area = 0.0;
#if MCPT_MAT_TEXELS > 2
    m.alpha = u_alpha; m.ior = u_ior; m.texture = -1; m.flags = uint(u_flags);
    m.sigma_a = vec3(0.0); m.fdr_int = u_fdr_int;
    m.scale = u_scale; m.eta = u_eta;
#endif
#if MCPT_FRESNEL_COMPLEX
    m.k = u_k;
#endif
#if MCPT_METALROUGH_SPECULAR
    m.mr_f0 = u_mr_f0; m.mr_f90 = u_mr_f90;
#endif
#if MCPT_MAT_ROUGH_PLASTIC
    m.base = 0;     // a rough plastic's table: texels of the bound material buffer
#endif
#if MCPT_SPECULAR_WEIGHTS
    m.spec_r = u_spec_r; m.spec_t = u_spec_t; m.spec_r_tex = -1; m.spec_t_tex = -1;
#endif
    return m;
}

void main() {
    int i = int(gl_FragCoord.y) * u_width + int(gl_FragCoord.x);
    o_out = uvec4(0u);
    if (i >= u_count) return;
    uvec4 p = texelFetch(u_probe, i);
    vec3 n = vec3(0.0, 0.0, 1.0);
    Material m = probe_material();
    material_side(m, u_front != 0);
    if (u_mode == 0 || u_mode == 1 || u_mode == 7) {
        BsdfSample s;
        bool ok = bsdf_sample(m, n, u_wo, u_front != 0, uintBitsToFloat(p.xyz), s);
        if (u_mode == 0) {
            if (ok) o_out = uvec4(floatBitsToUint(s.wi), floatBitsToUint(s.pdf));
        } else if (u_mode == 1) {
            uint flags = (ok ? 1u : 0u) | (s.delta ? 2u : 0u) | (s.transmit ? 4u : 0u);
            o_out = uvec4(floatBitsToUint(ok ? s.weight : vec3(0.0)), flags);
        } else {
            o_out = uvec4(floatBitsToUint(s.eta2), 0u, 0u, 0u);
        }
    } else if (u_mode == 2) {
        float pdf;
        vec3 f = bsdf_eval(m, n, u_wo, uintBitsToFloat(p.xyz), pdf);
        o_out = uvec4(floatBitsToUint(f), floatBitsToUint(pdf));
    }
#if MCPT_NEE
    else if (u_mode == 3) {
        float pmf, rest;
        int lt = int(light_pick(uintBitsToFloat(p.x), pmf, rest).x);
        o_out = uvec4(uint(lt), floatBitsToUint(pmf), floatBitsToUint(rest), 0u);
    } else if (u_mode == 4) {
        o_out = uvec4(floatBitsToUint(sample_triangle_bary(uintBitsToFloat(p.xy))), 0u, 0u);
    }
#endif
#if MCPT_MAT_ROUGH_DIELECTRIC
    else if (u_mode == 11) {
        float pdf;
        vec3 f = roughdielectric_eval(m, n, u_wo, uintBitsToFloat(p.xyz), true, pdf);
        o_out = uvec4(floatBitsToUint(f), floatBitsToUint(pdf));
    }
#endif
#if MCPT_FRESNEL_COMPLEX
    else if (u_mode == 8) {
        o_out = uvec4(floatBitsToUint(fresnel_conductor(uintBitsToFloat(p.x), vec3(uintBitsToFloat(p.y)), vec3(uintBitsToFloat(p.z)))), 0u);
    }
#endif
#if MCPT_LIGHT_SUN
    else if (u_mode == 9) {
        o_out = uvec4(floatBitsToUint(sample_cone(uintBitsToFloat(p.xy), u_wo, u_alpha)), 0u);
    }
#endif
#if MCPT_NEE && MCPT_LIGHT_ENV
    else if (u_mode == 10) {
        o_out = uvec4(floatBitsToUint(sample_uniform_sphere(uintBitsToFloat(p.xy))), 0u);
    }
#endif
#if MCPT_TEXTURES
    else if (u_mode == 5) {
        o_out = uvec4(floatBitsToUint(texture_rgb(int(p.z), uintBitsToFloat(p.xy))), 0u);
    }
#endif
#if MCPT_SMOOTH_NORMALS
    else if (u_mode == 6) {
        o_out = uvec4(floatBitsToUint(normalize(shading_normal_raw(int(p.x), uintBitsToFloat(p.yz)))), 0u);
    }
#endif
}

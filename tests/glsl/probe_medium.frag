// Test probe (tests/test_medium.py): the medium's GLSL routines, one per item, as float bits.
//   mode 0  hg_sample(d = u_d, g = u_g, u = p.xy)  -> (wi.xyz, pdf)
//   mode 1  hg_eval(cos = p.x, g = u_g)            -> (p, 0, 0, 0)
//   mode 2  medium_distance(t_hit = p.y, u = p.x)  -> (t, w.rgb)  (u_medium_* uniforms)
//   mode 3  equiangular_sample(frame of (o = 0, d = u_d, t_max = p.y, light at u_c), u = p.x)
//           -> (t, q(t), 0, 0)
#include "common.glsl"
#include "phase_hg.glsl"
#include "medium.glsl"
#include "medium_equiangular.glsl"
layout(binding = 6) uniform usamplerBuffer u_probe;
uniform int u_width;
uniform int u_count;
uniform int u_mode;
uniform vec3 u_d;
uniform float u_g;
uniform vec3 u_c;
layout(location = 0) out uvec4 o_out;

void main() {
    int i = int(gl_FragCoord.y) * u_width + int(gl_FragCoord.x);
    o_out = uvec4(0u);
    if (i >= u_count) return;
    vec4 p = uintBitsToFloat(texelFetch(u_probe, i));
    if (u_mode == 0) {
        float pdf;
        vec3 wi = hg_sample(u_d, u_g, p.xy, pdf);
        o_out = floatBitsToUint(vec4(wi, pdf));
    } else if (u_mode == 1) {
        o_out = floatBitsToUint(vec4(hg_eval(p.x, u_g), 0.0, 0.0, 0.0));
    } else if (u_mode == 3) {
        vec4 f = equiangular_frame(vec3(0.0), u_d, p.y, u_c);
        float t = equiangular_sample(f, p.x);
        o_out = floatBitsToUint(vec4(t, equiangular_pdf(f, t), 0.0, 0.0));
    } else {
        vec3 w;
        float t = medium_distance(medium_coeffs(0), p.y, p.x, w);
        o_out = floatBitsToUint(vec4(t, w));
    }
}

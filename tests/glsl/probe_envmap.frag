// Test probe (tests/test_envmap.py): one call of the environment map's GLSL (glsl/envmap.glsl) per
// item, results as float bits. Item i reads texel i of the probe buffer (floats p).
//   mode 0  env_sample(u = p.xy)          -> (d.xyz, pdf)
//   mode 1  env_sample_le(u = p.xy)       -> (le.rgb, pdf)
//   mode 2  env_radiance(d = p.xyz), env_pdf(d = p.xyz) -> (rgb, pdf)
#include "common.glsl"
#include "envmap.glsl"
layout(binding = 6) uniform usamplerBuffer u_probe;
uniform int u_width;
uniform int u_count;
uniform int u_mode;
layout(location = 0) out uvec4 o_out;

void main() {
    int i = int(gl_FragCoord.y) * u_width + int(gl_FragCoord.x);
    o_out = uvec4(0u);
    if (i >= u_count) return;
    vec4 p = uintBitsToFloat(texelFetch(u_probe, i));
    float pdf;
    if (u_mode == 0) {
        vec3 d = env_sample(p.xy, pdf);
        o_out = floatBitsToUint(vec4(d, pdf));
    } else if (u_mode == 1) {
        vec3 le;
        env_sample_le(p.xy, pdf, le);
        o_out = floatBitsToUint(vec4(le, pdf));
    } else {
        vec3 l = env_radiance(p.xyz);
        o_out = floatBitsToUint(vec4(l, env_pdf(p.xyz)));
    }
}

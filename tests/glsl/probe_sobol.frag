// Test probe (tests/test_sobol.py): the sobol sampler of glsl/sobol.glsl for item i with probe
// texel i = (pixel, dim, sample index, 0) -> (float bits of rand2_at(dim), of rand_at(dim), 0).
#include "sobol.glsl"
layout(binding = 6) uniform usamplerBuffer u_probe;
uniform int u_width;
uniform int u_count;
layout(location = 0) out uvec4 o_out;

void main() {
    int i = int(gl_FragCoord.y) * u_width + int(gl_FragCoord.x);
    if (i >= u_count) { o_out = uvec4(0u); return; }
    uvec4 p = texelFetch(u_probe, i);
    sobol_init(int(p.x), p.z);  // the renderer's index is the pass; here each item brings its own
    vec2 u2 = sobol_2d(int(p.y));
    float u1 = sobol_1d(int(p.y));
    o_out = uvec4(floatBitsToUint(u2.x), floatBitsToUint(u2.y), floatBitsToUint(u1), 0u);
}

// Test probe (tests/test_tbo.py): copy texel (row * width + column) of the probe buffer to the
// output unchanged, so the host can compare every packed bit with what it uploaded.
layout(binding = 6) uniform usamplerBuffer u_probe;
uniform int u_width;
uniform int u_count;
layout(location = 0) out uvec4 o_texel;

void main() {
    int i = int(gl_FragCoord.y) * u_width + int(gl_FragCoord.x);
    o_texel = i < u_count ? texelFetch(u_probe, i) : uvec4(0u);
}

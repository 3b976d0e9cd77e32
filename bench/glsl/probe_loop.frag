// Stability probe (bench/stability/runtime.py, llvmpipe-loop-limit): count the iterations a loop of
// u_n really runs in one fragment. llvmpipe stops every loop after 65535 back-edges in total.
uniform int u_n;
layout(location = 0) out uvec4 o_texel;

void main() {
    uint c = 0u;
    for (int i = 0; i < u_n; ++i) c++;
    o_texel = uvec4(c, 0u, 0u, 0u);
}

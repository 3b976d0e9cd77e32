// Stability probe (bench/stability/runtime.py, non-finite-test-under-fast-math): common.glsl's
// non_finite() on runtime NaN (0/0), +-Inf (1/0, FLT_MAX * 2) and finite extremes (FLT_MAX, a
// denormal, 0, -FLT_MAX). llvmpipe's fast-math folds isnan()/isinf(); the bit test must not be.
// Writes one bit per value (bit i set: value i flagged) into pixel 0.
#include "common.glsl"

uniform float u_zero;
uniform float u_one;
uniform float u_max;
uniform float u_tiny;
layout(location = 0) out uvec4 o_texel;

void main() {
    float v[8] = float[8](u_zero / u_zero, u_one / u_zero, -u_one / u_zero, u_max * 2.0,
                          u_max, u_tiny, u_zero, -u_max);
    uint bits = 0u;
    for (int i = 0; i < 8; ++i) if (non_finite(v[i])) bits |= 1u << i;
    o_texel = uvec4(bits, 0u, 0u, 0u);
}

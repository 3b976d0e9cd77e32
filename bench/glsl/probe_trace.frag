// Probe (bench/stability/watertight.py; tests/test_bvh_gpu.py, test_bvh_sah.py): trace the ray
// stored in texels 2i, 2i+1 of the probe buffer (origin.xyz, direction.xyz as float bits) through
// the real traversal and return (t bits, triangle index + 1, bary bits) -- 0 for a miss.
// PROBE_VISIBLE defined: the shadow-ray query instead, visible(ray, tmax) with tmax's bits in the
// origin texel's w: (1 if visible else 0, 0, 0, 0).
#include "common.glsl"
#include "bvh.glsl"
layout(binding = 6) uniform usamplerBuffer u_probe;
uniform int u_width;
uniform int u_count;
layout(location = 0) out uvec4 o_hit;

void main() {
    int i = int(gl_FragCoord.y) * u_width + int(gl_FragCoord.x);
    o_hit = uvec4(0u);
    if (i >= u_count) return;
    Ray r;
    r.o = uintBitsToFloat(texelFetch(u_probe, 2 * i).xyz);
    r.d = uintBitsToFloat(texelFetch(u_probe, 2 * i + 1).xyz);
#ifdef PROBE_VISIBLE
    o_hit.x = visible(r, uintBitsToFloat(texelFetch(u_probe, 2 * i).w)) ? 1u : 0u;
    return;
#endif
    Hit h;
    if (trace_closest(r, h)) o_hit = uvec4(floatBitsToUint(h.t), uint(h.tri + 1), floatBitsToUint(h.bary));
}

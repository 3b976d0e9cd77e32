// Emissive triangles for next-event estimation (host side: mcpt/shading/lights.py).
// One RGBA32UI texel per emissive triangle: (triangle, cdf upper bound bits, pmf bits, 0), picked
// with probability proportional to emitted power x area. A point is then sampled uniformly on
// the triangle, so the area density is pmf / area = luminance(Le) / total power.
layout(binding = 3) uniform usamplerBuffer u_lights;
uniform int u_light_count;

int light_pick(float u, out float pmf) {
#if MCPT_SINGLE_LIGHT
    uvec4 e = texelFetch(u_lights, 0);
#else
    // First entry whose cdf upper bound exceeds u (binary search over inclusive prefix sums).
    int lo = 0, hi = u_light_count - 1;
    while (lo < hi) {
        LOOP_TICK();
        int mid = (lo + hi) >> 1;
        if (uintBitsToFloat(texelFetch(u_lights, mid).y) > u) hi = mid; else lo = mid + 1;
    }
    uvec4 e = texelFetch(u_lights, lo);
#endif
    pmf = uintBitsToFloat(e.z);
    return int(e.x);
}

// Uniform point on a triangle (square-root parametrisation, pbrt-v4 SampleUniformTriangle).
vec2 sample_triangle_bary(vec2 u) {
    float su = sqrt(u.x);
    return vec2(u.y * su, 1.0 - su);  // (b1, b2) for v1, v2
}

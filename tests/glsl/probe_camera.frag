// Test probe (tests/test_camera.py): the renderer's camera code (glsl/camera.glsl and
// glsl/pixel_filter.glsl) per item, results as float bits. Item i reads texel i of the probe
// buffer: p.xy the camera's random numbers, p.zw the pixel (uints); uniform u_lens: the lens numbers.
//   mode 0  filter_jitter(pixel, u)  -> (jitter.xy, 0, 0)   (MCPT_FILTER)
//   mode 1  camera_ray(pixel, u)     -> (direction.xyz, 0)
//   mode 2  camera_ray(pixel, u)     -> (origin.xyz, 0)
//   mode 3  concentric_disk(u)       -> (disk.xy, 0, 0)       (MCPT_THIN_LENS)
#include "common.glsl"
#include "sampler.glsl"
#include "camera.glsl"
layout(binding = 6) uniform usamplerBuffer u_probe;
uniform int u_width;
uniform int u_count;
uniform int u_mode;
uniform vec2 u_lens;
layout(location = 0) out uvec4 o_out;

void main() {
    int i = int(gl_FragCoord.y) * u_width + int(gl_FragCoord.x);
    o_out = uvec4(0u);
    if (i >= u_count) return;
    uvec4 p = texelFetch(u_probe, i);
    vec2 u = uintBitsToFloat(p.xy);
    ivec2 pixel = ivec2(p.zw);
#if MCPT_FILTER
    if (u_mode == 0) o_out = uvec4(floatBitsToUint(filter_jitter(pixel, u, u_resolution)), 0u, 0u);
#endif
#if MCPT_THIN_LENS
    if (u_mode == 3) o_out = uvec4(floatBitsToUint(concentric_disk(u)), 0u, 0u);
#endif
    Ray r = camera_ray(pixel, u, u_lens);
    if (u_mode == 1) o_out = uvec4(floatBitsToUint(r.d), 0u);
    if (u_mode == 2) o_out = uvec4(floatBitsToUint(r.o), 0u);
}

// Pinhole camera, scene.json convention: pixel (i, j) counted from the left and the TOP, the
// sample at (i + sx, j + sy). u_cam_right/u_cam_up are pre-scaled on the host by
// tan(vfov/2) * aspect and tan(vfov/2) (mcpt/shading/camera.py). The camera sits at the origin: the
// scene is rebased relative to it on the CPU. (sx, sy): the camera's two random numbers, uniform in
// the pixel (box filter), or drawn from the pixel filter (MCPT_FILTER: glsl/pixel_filter.glsl).
uniform vec3 u_cam_forward;
uniform vec3 u_cam_right;
uniform vec3 u_cam_up;
uniform ivec2 u_resolution;
#if MCPT_FILTER
#include "pixel_filter.glsl"
#endif

Ray camera_ray(ivec2 pixel, vec2 u) {
#if MCPT_FILTER
    vec2 jitter = filter_jitter(pixel, u, u_resolution);
#else
    vec2 jitter = u;
#endif
    vec2 ndc = vec2(2.0 * (float(pixel.x) + jitter.x) / float(u_resolution.x) - 1.0,
                    1.0 - 2.0 * (float(pixel.y) + jitter.y) / float(u_resolution.y));
    Ray r;
    r.o = vec3(0.0);
    r.d = normalize(u_cam_forward + ndc.x * u_cam_right + ndc.y * u_cam_up);
    return r;
}

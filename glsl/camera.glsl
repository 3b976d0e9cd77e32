// The camera (host: mcpt/shading/camera.py), scene.json convention: pixel (i, j) counted from the
// left and the TOP, the sample at film position (i + sx, j + sy), ndc in [-1, 1]^2. The camera sits
// at the origin: the scene is rebased relative to it on the CPU.
//   pinhole (default)  direction f + x r + y u; r, u pre-scaled by tan(vfov/2) aspect, tan(vfov/2)
//   MCPT_THIN_LENS     Mitsuba's thinlens: from a point of the aperture disk toward the point of
//                      the focus plane (distance u_focus_distance along f) that the pinhole ray
//                      reaches, so that plane stays sharp
//   MCPT_ORTHO         origin x r + y u (r, u pre-scaled by the half width / height), direction f
// (sx, sy): the camera's two random numbers, uniform in the pixel (box filter), or drawn from the
// pixel filter (MCPT_FILTER: glsl/pixel_filter.glsl).
uniform vec3 u_cam_forward;
uniform vec3 u_cam_right;
uniform vec3 u_cam_up;
uniform ivec2 u_resolution;
#if MCPT_CAMERA_MOVES
// Issue #26: an animated camera's eye relative to the geometry's origin (the rest pose's camera
// position, mcpt/scene/animation.py), so a moving camera changes uniforms, not the upload.
uniform vec3 u_cam_eye;
#endif
#if MCPT_FILTER
#include "pixel_filter.glsl"
#endif
#if MCPT_THIN_LENS
uniform vec3 u_lens_right;       // unit right and up times the aperture radius (world units)
uniform vec3 u_lens_up;
uniform float u_focus_distance;  // world units along u_cam_forward

// Shirley & Chiu 1997, "A low distortion map between disk and square" (as Mitsuba's
// warp::square_to_uniform_disk_concentric): uniform on the unit disk, area-preserving.
vec2 concentric_disk(vec2 u) {
    vec2 o = 2.0 * u - 1.0;
    if (o.x == 0.0 && o.y == 0.0) return vec2(0.0);
    bool wide = abs(o.x) > abs(o.y);
    float r = wide ? o.x : o.y;
    float phi = wide ? 0.25 * PI * (o.y / o.x) : 0.5 * PI - 0.25 * PI * (o.x / o.y);
    return r * vec2(cos(phi), sin(phi));
}
#endif

// The ray through film position `pixel + u` (after the filter), with lens numbers `lens`
// (read only by the thin lens).
Ray camera_ray(ivec2 pixel, vec2 u, vec2 lens) {
#if MCPT_FILTER
    vec2 jitter = filter_jitter(pixel, u, u_resolution);
#else
    vec2 jitter = u;
#endif
    vec2 ndc = vec2(2.0 * (float(pixel.x) + jitter.x) / float(u_resolution.x) - 1.0,
                    1.0 - 2.0 * (float(pixel.y) + jitter.y) / float(u_resolution.y));
    Ray r;
#if MCPT_ORTHO
    r.o = ndc.x * u_cam_right + ndc.y * u_cam_up;
    r.d = u_cam_forward;
#elif MCPT_THIN_LENS
    vec2 a = concentric_disk(lens);
    r.o = a.x * u_lens_right + a.y * u_lens_up;
    r.d = normalize((u_cam_forward + ndc.x * u_cam_right + ndc.y * u_cam_up) * u_focus_distance - r.o);
#else
    r.o = vec3(0.0);
    r.d = normalize(u_cam_forward + ndc.x * u_cam_right + ndc.y * u_cam_up);
#endif
#if MCPT_CAMERA_MOVES
    r.o += u_cam_eye;  // issue #26: the eye moved from the geometry's origin
#endif
    return r;
}

// The camera ray of the current sample: its numbers from the sampler (glsl/sampler.glsl).
Ray camera_sample(ivec2 pixel) {
#if MCPT_THIN_LENS
    return camera_ray(pixel, rand2_at(DIM_CAMERA), rand2_at(DIM_LENS));
#else
    return camera_ray(pixel, rand2_at(DIM_CAMERA), vec2(0.0));
#endif
}

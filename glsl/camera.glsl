// Pinhole camera, scene.json convention: pixel (i, j) counted from the left and the TOP, jitter
// (sx, sy) uniform in the pixel (box filter). u_cam_right/u_cam_up are pre-scaled on the host
// by tan(vfov/2) * aspect and tan(vfov/2) (mcpt/shading/camera.py). The camera sits at the origin: the
// scene is rebased relative to it on the CPU.
uniform vec3 u_cam_forward;
uniform vec3 u_cam_right;
uniform vec3 u_cam_up;
uniform ivec2 u_resolution;
#if MCPT_CAMERA_MOVES
// Issue #26: an animated camera's eye relative to the geometry's origin (the rest pose's camera
// position, mcpt/scene/animation.py), so a moving camera changes uniforms, not the upload.
uniform vec3 u_cam_eye;
#endif

Ray camera_ray(ivec2 pixel, vec2 jitter) {
    vec2 ndc = vec2(2.0 * (float(pixel.x) + jitter.x) / float(u_resolution.x) - 1.0,
                    1.0 - 2.0 * (float(pixel.y) + jitter.y) / float(u_resolution.y));
    Ray r;
#if MCPT_CAMERA_MOVES
    r.o = u_cam_eye;
#else
    r.o = vec3(0.0);
#endif
    r.d = normalize(u_cam_forward + ndc.x * u_cam_right + ndc.y * u_cam_up);
    return r;
}

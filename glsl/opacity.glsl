// Opacity cut-outs (host side: mcpt/shading/opacity.py, which documents the convention): the
// any-hit test of closest-hit and shadow rays (glsl/bvh.glsl trace_closest, visible). A triangle
// whose material has an opacity texture is not hit where the texture says it is transparent:
// every ray (camera, BSDF, shadow) goes through, so nothing leaks and nothing is counted twice.
// Included only with MCPT_OPACITY.
#include "geometry.glsl"

#include "texture.glsl"
// u_normal_maps: the per-material texel, the opacity texture in .w.
#include "normal_map.glsl"

// A hash of the ray and the triangle (no state, no random dimension: a ray meeting the same
// point twice decides the same way), uniform in [0, 1) (PCG output permutation, O'Neill 2014).
float opacity_hash(Ray r, int tri) {
    uvec3 o = floatBitsToUint(r.o), d = floatBitsToUint(r.d);
    uint h = uint(tri) * 747796405u + 2891336453u;
    h ^= o.x + 0x9E3779B9u * (o.y ^ (o.z << 7)) + 0x85EBCA6Bu * (d.x ^ (d.y << 11) ^ (d.z << 3));
    h = ((h >> ((h >> 28u) + 4u)) ^ h) * 277803737u;
    h = (h >> 22u) ^ h;
    return float(h >> 8) * (1.0 / 16777216.0);
}

// True when the ray passes through triangle `tri` at barycentrics `bary`: its opacity there (the
// texture's luminance) is below the material's cutoff, or, without a cutoff (stochastic, glTF
// BLEND / Mitsuba's mask), below the ray's hash.
bool opacity_pass(Ray r, int tri, vec2 bary) {
    uvec4 m = texelFetch(u_normal_maps, tri_material(tri));
    if (m.w == 0xffffffffu) return false;
    float alpha = dot(texture_rgb(int(m.w), tri_uv(tri, bary)), vec3(0.2126, 0.7152, 0.0722));
    float cutoff = float(m.y >> 16) * (1.0 / 65535.0);
    return alpha < ((m.y & 4u) != 0u ? cutoff : opacity_hash(r, tri));
}

// Surfaces a ray may cross through cut-outs before it counts as blocked (a bound on the loop;
// past it the next surface is taken as opaque: foliage of more layers darkens slightly).
#define OPACITY_MAX_LAYERS 16

// trace() with the any-hit test done outside traversal: the closest hit before tmax, and while it
// lies on a transparent texel the ray goes on from just past it (any_hit: a shadow ray, which
// first takes any hit and is done if that one is opaque). Traversal's
// loop body stays as it is (llvmpipe pays for a loop body on every iteration, issue #14: the test
// inside it cost 5-10x on the bunny), and only rays that meet a cut-out trace again.
bool trace_through(Ray r, float tmax, bool any_hit, inout Hit h) {
    if (any_hit) {  // a shadow ray: an opaque hit, whichever, ends it at once
        h.t = tmax; h.tri = -1;
        if (!trace(r, h, true)) return false;
        if (!opacity_pass(r, h.tri, h.bary)) return true;
    }
    Ray q = r;
    float done = 0.0;  // distance along r already crossed
    for (int layer = 0; layer < OPACITY_MAX_LAYERS; ++layer) {
        LOOP_TICK();
        h.t = tmax - done; h.tri = -1;
        if (!trace(q, h, false)) return false;
        if (!opacity_pass(r, h.tri, h.bary)) {
            h.t += done;
            return true;
        }
        vec3 x = q.o + h.t * q.d;
        vec3 n = tri_normal_raw(h.tri);
        vec3 xo = offset_ray(x, normalize(dot(n, q.d) > 0.0 ? n : -n));  // past the surface
        done += length(xo - q.o);
        q.o = xo;
    }
    h.t += done;
    return true;
}

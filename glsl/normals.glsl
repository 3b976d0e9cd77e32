// Smooth shading normals (host side: mcpt/shading/normals.py pack_normals). One RGBA32UI texel per
// triangle (BVH order): the three corner normals, octahedral-encoded as two 16-bit snorms each
// (Cigolle et al. 2014, "A Survey of Efficient Representations for Independent Unit Vectors").
// The buffer and its decoding are compiled only with MCPT_SMOOTH_NORMALS; shading_normal always.
#include "common.glsl"
#include "geometry.glsl"
#include "materials.glsl"

#if MCPT_SMOOTH_NORMALS || MCPT_NORMAL_MAPS
// Also the tangents' decoding (glsl/normal_map.glsl).
vec3 oct_decode(uint v) {
    return oct_unfold(unpackSnorm2x16(v));  // not unit: the interpolation below normalises once
}
#endif

#if MCPT_SMOOTH_NORMALS
layout(binding = 7) uniform usamplerBuffer u_normals;

// The interpolated vertex normal at barycentrics (b1, b2); unnormalised (may be zero where the
// corner normals cancel, which the caller must treat as "no shading normal").
vec3 shading_normal_raw(int tri, vec2 bary) {
    uvec4 q = texelFetch(u_normals, tri);
    vec3 n0 = normalize(oct_decode(q.x)), n1 = normalize(oct_decode(q.y)), n2 = normalize(oct_decode(q.z));
    return (1.0 - bary.x - bary.y) * n0 + bary.x * n1 + bary.y * n2;
}
#endif

// The normal the BSDF sees at hit h (ng: the geometric normal turned to the side the path came
// from, cos_o = dot(n, ray.d), wo = -ray.d): the interpolated vertex normal, turned the same
// way, for a material with smooth normals; where it faces away from wo (silhouettes of coarse
// meshes) or is undefined, ng.
vec3 shading_normal(Material m, Hit h, vec3 ng, float cos_o, vec3 wo) {
    vec3 ns = ng;
#if MCPT_SMOOTH_NORMALS
    if ((m.flags & MAT_FLAG_SMOOTH) != 0u && !HIT_IS_SPHERE(h.tri)) {  // a sphere's ng is exact
        vec3 sn = normalize(shading_normal_raw(h.tri, h.bary));
        sn = cos_o < 0.0 ? sn : -sn;
        if (dot(sn, wo) > 0.0) ns = sn;
    }
#endif
    return ns;
}

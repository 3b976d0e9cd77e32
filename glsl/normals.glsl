// Smooth shading normals (host side: mcpt/shading/normals.py pack_normals). One RGBA32UI texel per
// triangle (BVH order): the three corner normals, octahedral-encoded as two 16-bit snorms each
// (Cigolle et al. 2014, "A Survey of Efficient Representations for Independent Unit Vectors").
layout(binding = 7) uniform usamplerBuffer u_normals;

vec3 oct_decode(uint v) {
    vec2 p = unpackSnorm2x16(v);
    vec3 n = vec3(p, 1.0 - abs(p.x) - abs(p.y));
    float t = max(-n.z, 0.0);
    n.x += n.x >= 0.0 ? -t : t;
    n.y += n.y >= 0.0 ? -t : t;
    return n;  // not unit: the interpolation below normalises once
}

// The interpolated vertex normal at barycentrics (b1, b2); unnormalised (may be zero where the
// corner normals cancel, which the caller must treat as "no shading normal").
vec3 shading_normal_raw(int tri, vec2 bary) {
    uvec4 q = texelFetch(u_normals, tri);
    vec3 n0 = normalize(oct_decode(q.x)), n1 = normalize(oct_decode(q.y)), n2 = normalize(oct_decode(q.z));
    return (1.0 - bary.x - bary.y) * n0 + bary.x * n1 + bary.y * n2;
}

// Sun disks: directional lights with an angular diameter (host side: mcpt/shading/light_sun.py;
// their entry data: glsl/light_punctual.glsl). Not delta lights: next-event estimation samples the
// disk's cone uniformly (pbrt-v4 SampleUniformCone), and a ray that leaves the scene inside the
// cone sees the disk's radiance, weighted against that density by the power heuristic.
#define MAX_SUNS 4
uniform int u_sun_count;
uniform vec4 u_sun_dir[MAX_SUNS];  // unit direction to the sun, cos of its angular radius
uniform vec4 u_sun_le[MAX_SUNS];   // radiance (W sr^-1 m^-2), pick probability / solid angle (sr^-1)

// Uniform direction in the cone of cos half-angle cos_max about the unit axis a.
vec3 sample_cone(vec2 u, vec3 a, float cos_max) {
    float c = 1.0 - u.x * (1.0 - cos_max);
    float s = sqrt(max(0.0, 1.0 - c * c));
    float phi = 2.0 * PI * u.y;
    vec3 t, b;
    onb(a, t, b);
    return c * a + s * (cos(phi) * t + sin(phi) * b);
}

// P's ray (direction d) left the scene: every sun disk it points into, MIS-weighted against NEE.
void sun_escaped(inout Path P, vec3 d) {
    for (int i = 0; i < u_sun_count; ++i) {
        if (dot(d, u_sun_dir[i].xyz) >= u_sun_dir[i].w) {
            P.L += P.beta * u_sun_le[i].rgb * emitter_mis(P, u_sun_le[i].w);
        }
    }
}

// Point, spot and directional lights (host side: mcpt/shading/light_punctual.py, which documents
// the PUNCTUAL_TEXELS data texels an entry's payload points at). Delta lights: no ray can hit
// them, so next-event estimation alone finds them, with weight 1 (no MIS); the sample's pdf is
// the pick probability and L what arrives: I / d^2 (point, spot) or the irradiance E (directional),
// so that f cos L / pdf is the estimate (Mitsuba 3: src/emitters/point.cpp, spot.cpp,
// directional.cpp sample_direction).

vec4 light_texel(int at) { return uintBitsToFloat(texelFetch(u_lights, at)); }

#if MCPT_LIGHT_SPOT
// Mitsuba 3's spot profile (src/emitters/spot.cpp falloff_curve) at cos_theta from the axis;
// s = (cos cutoff, cos beam, cutoff rad, 1 / (cutoff - beam)): 1 inside the beam, then linear
// in angle down to 0 at the cutoff.
float spot_falloff(float cos_theta, vec4 s) {
    if (cos_theta <= s.x) return 0.0;
    if (cos_theta >= s.y) return 1.0;
    return (s.z - acos(cos_theta)) * s.w;
}
#endif

// The punctual light of entry e (picked with probability pmf) seen from xo; u: a sun disk's sample.
void punctual_sample(inout LightSample ls, uvec4 e, float pmf, vec3 xo, vec2 u) {
    int at = int(e.x);
    vec3 value = light_texel(at + 1).rgb;  // intensity W/sr, irradiance W/m^2, or sun radiance
    ls.delta = true;
    ls.pdf = pmf;
#if MCPT_LIGHT_SUN
    if (e.w == LIGHT_SUN) {  // a direction in the disk's cone (glsl/light_sun.glsl)
        vec4 cone = light_texel(at + 3);  // cos half-angle, 1 / solid angle
        ls.wi = sample_cone(u, -light_texel(at + 2).xyz, cone.x);
        ls.dist = INF;
        ls.L = value;
        ls.pdf = pmf * cone.y;
        ls.delta = false;
        return;
    }
#endif
#if MCPT_LIGHT_DIRECTIONAL
    if (e.w == LIGHT_DIRECTIONAL) {
        ls.wi = -light_texel(at + 2).xyz;  // towards the sun
        ls.dist = INF;
        ls.L = value;
        return;
    }
#endif
    vec3 dv = light_texel(at).xyz - xo;
    float d2 = dot(dv, dv);
    ls.dist = sqrt(d2);
    ls.wi = dv / ls.dist;
    ls.L = value / d2;  // inverse-square law
#if MCPT_LIGHT_SPOT
    if (e.w == LIGHT_SPOT) ls.L *= spot_falloff(-dot(ls.wi, light_texel(at + 2).xyz), light_texel(at + 3));
#endif
}

// The procedural checkerboard (host side: mcpt/shading/checkerboard.py, which cites Mitsuba's
// convention): color0 where frac(s) > 1/2 and frac(t) > 1/2 agree, color1 elsewhere, at the
// already transformed coordinates st. `data`: its first colour texel in u_textures.
vec3 checkerboard_rgb(int data, vec2 st) {
    bvec2 hi = greaterThan(st - floor(st), vec2(0.5));
    return uintBitsToFloat(texelFetch(u_textures, data + (hi.x == hi.y ? 0 : 1)).xyz);
}

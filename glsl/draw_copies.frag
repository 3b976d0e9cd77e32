// Draw copies (host side: mcpt/gpu/draw_copies.py): adds up the u_count side-by-side copies of
// each accumulation target that one draw of a small image wrote into its scratch targets, into
// the image's targets (additive blending). The copies are added in a fixed order (copy 0 first),
// so a draw adds the same float32 numbers wherever a render starts, stops or resumes.
layout(binding = 12) uniform sampler2D u_copy0;
#if COPY_TARGETS > 1
layout(binding = 13) uniform sampler2D u_copy1;
#endif
#if COPY_TARGETS > 2
layout(binding = 14) uniform sampler2D u_copy2;
#endif
#if COPY_TARGETS > 3
layout(binding = 15) uniform sampler2D u_copy3;
#endif
uniform int u_width;  // the image's width in pixels (one copy)
uniform int u_count;  // copies
layout(location = 0) out vec4 o_0;
layout(location = 1) out vec4 o_1;
layout(location = 2) out vec4 o_2;
layout(location = 3) out vec4 o_3;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 s0 = vec4(0.0), s1 = vec4(0.0), s2 = vec4(0.0), s3 = vec4(0.0);
    for (int c = 0; c < u_count; c++) {
        ivec2 q = ivec2(p.x + c * u_width, p.y);
        s0 += texelFetch(u_copy0, q, 0);
#if COPY_TARGETS > 1
        s1 += texelFetch(u_copy1, q, 0);
#endif
#if COPY_TARGETS > 2
        s2 += texelFetch(u_copy2, q, 0);
#endif
#if COPY_TARGETS > 3
        s3 += texelFetch(u_copy3, q, 0);
#endif
    }
    o_0 = s0;
    o_1 = s1;
    o_2 = s2;
    o_3 = s3;
}

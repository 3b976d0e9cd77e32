// One triangle that covers the viewport; positions come from gl_VertexID, so no vertex buffer.
//
// issue #24 item 8 (mcpt/gpu/bands.py): with u_parts.y > 1, part u_parts.x of a draw cut into
// u_parts.y parts (a power of two up to 16): in each 64x64 tile of the window (llvmpipe's unit of
// work for one thread) of tile rows u_parts.z.., u_parts.w tiles a row, its 16x16 blocks
// m = part + j * parts (m = 0..15: x = m & 3, y = m >> 2), two triangles each, 6 * 16 / parts
// vertices a tile; every tile holds some of every part, so a part keeps all threads busy. Blocks
// past the window are clipped. The fragment shader reads gl_FragCoord alone: whatever covers a
// pixel, its numbers are the same.
uniform ivec4 u_parts;
uniform ivec2 u_resolution;

const ivec2 CORNERS[6] = ivec2[6](ivec2(0, 0), ivec2(1, 0), ivec2(1, 1), ivec2(0, 0), ivec2(1, 1), ivec2(0, 1));

void main() {
    if (u_parts.y <= 1) {
        vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
        gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
        return;
    }
    int per = 16 / u_parts.y;
    int quad = gl_VertexID / 6, corner = gl_VertexID - quad * 6;
    int tile = quad / per, m = u_parts.x + (quad - tile * per) * u_parts.y;
    ivec2 t = ivec2(tile % u_parts.w, u_parts.z + tile / u_parts.w);
    vec2 px = vec2((t * 4 + ivec2(m & 3, m >> 2) + CORNERS[corner]) * 16);
    gl_Position = vec4(px / vec2(u_resolution) * 2.0 - 1.0, 0.0, 1.0);
}

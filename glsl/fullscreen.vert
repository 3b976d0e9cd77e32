// One triangle that covers the viewport; positions come from gl_VertexID, so no vertex buffer.
//
// issue #24 item 8 (mcpt/gpu/bands.py): with u_parts.y > 1, part u_parts.x of a draw cut into
// u_parts.y parts (a power of two up to 16), drawn as points: in each 64x64 tile of the window
// (llvmpipe's unit of work for one thread) of tile rows u_parts.z.., u_parts.w tiles a row, its
// 16x16 blocks m = part + j * parts (m = 0..15: x = m & 3, y = m >> 2), one point of size 16 each
// (a square: two triangles would shade the 4x4 pixel groups their diagonal crosses twice); every
// tile holds some of every part, so a part keeps all threads busy. The viewport is the window
// padded to whole tiles (a point whose centre is outside it is not drawn). The fragment shader
// reads gl_FragCoord alone: whatever covers a pixel, its numbers are the same.
uniform ivec4 u_parts;
uniform ivec2 u_resolution;

void main() {
    if (u_parts.y <= 1) {
        vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
        gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
        return;
    }
    int per = 16 / u_parts.y;
    int tile = gl_VertexID / per, m = u_parts.x + (gl_VertexID - tile * per) * u_parts.y;
    ivec2 t = ivec2(tile % u_parts.w, u_parts.z + tile / u_parts.w);
    vec2 centre = vec2((t * 4 + ivec2(m & 3, m >> 2)) * 16 + 8);
    vec2 padded = vec2(((u_resolution + 63) >> 6) << 6);
    gl_Position = vec4(centre / padded * 2.0 - 1.0, 0.0, 1.0);
    gl_PointSize = 16.0;
}

// Material table (host side: mcpt/materials.py). Two RGBA32UI texels per material:
//   (albedo.rgb float bits, type), (emission.rgb float bits, light_pdf_area float bits)
// light_pdf_area = luminance(Le) / total emitted power: the density, per unit area, with which
// next-event estimation picks a point on a triangle of this material (needed for MIS).
layout(binding = 4) uniform usamplerBuffer u_materials;

struct Material { vec3 albedo; int type; vec3 emission; float light_pdf_area; };

Material material(int id) {
    uvec4 a = texelFetch(u_materials, 2 * id);
    uvec4 b = texelFetch(u_materials, 2 * id + 1);
    Material m;
    m.albedo = uintBitsToFloat(a.xyz); m.type = int(a.w);
    m.emission = uintBitsToFloat(b.xyz); m.light_pdf_area = uintBitsToFloat(b.w);
    return m;
}

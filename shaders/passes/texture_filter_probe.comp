// texture_filter_probe.comp - measures the texture unit's precision (viewer.gl.context.
// texture_filter_bits): reads a 0 | 1 edge between two texel centres (u_mip 0: the bilinear weight)
// or between two mip levels (u_mip 1: the lod fraction) at u_count evenly spaced positions.
layout(local_size_x = 256) in;
uniform sampler2D u_tex;
uniform uint u_count;
uniform int u_mip;  // 0: bilinear weight along x on level 0; 1: lod fraction between levels 0, 1
layout(std430, binding = 0) writeonly buffer Out { float outv[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    float f = float(i) / float(u_count);
    outv[i] = u_mip == 0 ? textureLod(u_tex, vec2((1.5 + f) / 4.0, 0.5), 0.0).r
                         : textureLod(u_tex, vec2(0.5, 0.5), f).r;
}

#version 460
// The device BVH build, step 1: each triangle's Morton code, 10 bits an axis of its
// center in the mesh box, as the key of the sort; its file index as the value.
#include "common.glsl"

layout(local_size_x = 256) in;

// Spread the low 10 bits of `x` to every third bit.
uint spread(uint x) {
    x = (x | (x << 16u)) & 0x030000FFu;
    x = (x | (x << 8u)) & 0x0300F00Fu;
    x = (x | (x << 4u)) & 0x030C30C3u;
    x = (x | (x << 2u)) & 0x09249249u;
    return x;
}

void main() {
    uint i = flat_group() * 256u + gl_LocalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    uint w = 10u * i;
    vec3 v0 = uintBitsToFloat(uvec3(src_words[w], src_words[w + 1u], src_words[w + 2u]));
    vec3 e1 = uintBitsToFloat(uvec3(src_words[w + 3u], src_words[w + 4u], src_words[w + 5u]));
    vec3 e2 = uintBitsToFloat(uvec3(src_words[w + 6u], src_words[w + 7u], src_words[w + 8u]));
    vec3 center = v0 + (e1 + e2) * (1.0 / 3.0);
    uvec3 q = uvec3(clamp((center - pc.lo.xyz) * pc.cells.xyz, vec3(0.0), vec3(1023.0)));
    sort_words[i] = (spread(q.x) << 2u) | (spread(q.y) << 1u) | spread(q.z);
    sort_words[pc.count + i] = i;
}

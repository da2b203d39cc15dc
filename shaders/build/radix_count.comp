#version 460
// The device BVH build, a radix pass's first step: how many keys of each block have each
// digit, written digit-major so that one scan gives every block its place per digit.
#include "common.glsl"

layout(local_size_x = SORT_THREADS) in;

shared uint counts[RADIX];

void main() {
    uint t = gl_LocalInvocationID.x;
    uint block = flat_group();
    if (block >= pc.blocks) {
        return;
    }
    if (t < RADIX) {
        counts[t] = 0u;
    }
    barrier();
    uint keys = pc.flip == 0u ? 0u : 2u * pc.count;
    uint first = block * SORT_BLOCK;
    for (uint k = 0u; k < SORT_ITEMS; k++) {
        // Strided: neighbouring threads read neighbouring keys.
        uint i = first + k * SORT_THREADS + t;
        if (i < pc.count) {
            uint digit = (sort_words[keys + i] >> pc.shift) & (RADIX - 1u);
            atomicAdd(counts[digit], 1u);
        }
    }
    barrier();
    if (t < RADIX) {
        histogram[t * pc.blocks + block] = counts[t];
    }
}

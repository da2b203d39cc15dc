#version 460
// The device BVH build, a radix pass's last step: each key and value moved to its place.
// A thread ranks its own run of SORT_ITEMS keys, so the order within a digit is the input
// order (the sort is stable): the block's place for the digit (the scan) + the keys of
// that digit in the threads before + those before it in its own run.
#include "common.glsl"

layout(local_size_x = SORT_THREADS) in;

// Digit-major: the thread's count of each digit, scanned over the threads in place.
shared uint ranks[RADIX * SORT_THREADS];

void main() {
    uint t = gl_LocalInvocationID.x;
    uint block = flat_group();
    if (block >= pc.blocks) {
        return;
    }
    uint src = pc.flip == 0u ? 0u : 2u * pc.count;
    uint dst = pc.flip == 0u ? 2u * pc.count : 0u;
    uint first = block * SORT_BLOCK + t * SORT_ITEMS;
    uint own[RADIX];
    for (uint d = 0u; d < RADIX; d++) {
        own[d] = 0u;
    }
    for (uint k = 0u; k < SORT_ITEMS; k++) {
        uint i = first + k;
        if (i < pc.count) {
            own[(sort_words[src + i] >> pc.shift) & (RADIX - 1u)]++;
        }
    }
    for (uint d = 0u; d < RADIX; d++) {
        ranks[d * SORT_THREADS + t] = own[d];
    }
    barrier();
    // One thread a digit scans its counts over the threads (exclusive).
    if (t < RADIX) {
        uint sum = 0u;
        for (uint u = 0u; u < SORT_THREADS; u++) {
            uint c = ranks[t * SORT_THREADS + u];
            ranks[t * SORT_THREADS + u] = sum;
            sum += c;
        }
    }
    barrier();
    for (uint d = 0u; d < RADIX; d++) {
        own[d] = histogram[d * pc.blocks + block] + ranks[d * SORT_THREADS + t];
    }
    for (uint k = 0u; k < SORT_ITEMS; k++) {
        uint i = first + k;
        if (i < pc.count) {
            uint key = sort_words[src + i];
            uint d = (key >> pc.shift) & (RADIX - 1u);
            uint to = own[d]++;
            sort_words[dst + to] = key;
            sort_words[dst + pc.count + to] = sort_words[src + pc.count + i];
        }
    }
}

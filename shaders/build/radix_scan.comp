#version 460
// The device BVH build, a radix pass's second stride: the digit-major block counts scanned
// (exclusive) in place, by one work group: each thread sums a run of them, the runs' sums
// are scanned in shared memory, and each thread writes its run's prefixes. A few hundred
// thousand counts at 100M triangles: a fraction of a millisecond.
#include "common.glsl"

#define SCAN_THREADS 1024u
layout(local_size_x = SCAN_THREADS) in;

shared uint sums[SCAN_THREADS];

void main() {
    uint t = gl_LocalInvocationID.x;
    uint total = RADIX * pc.blocks;
    uint run = (total + SCAN_THREADS - 1u) / SCAN_THREADS;
    uint first = min(t * run, total);
    uint end = min(first + run, total);
    uint sum = 0u;
    for (uint i = first; i < end; i++) {
        sum += histogram[i];
    }
    sums[t] = sum;
    barrier();
    // Hillis-Steele inclusive scan of the runs' sums.
    for (uint stride = 1u; stride < SCAN_THREADS; stride <<= 1u) {
        uint add = t >= stride ? sums[t - stride] : 0u;
        barrier();
        sums[t] += add;
        barrier();
    }
    uint prefix = sums[t] - sum;
    for (uint i = first; i < end; i++) {
        uint c = histogram[i];
        histogram[i] = prefix;
        prefix += c;
    }
}

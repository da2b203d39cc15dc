#version 450
// The compute tracer: one invocation per pixel, hits found by our BVH or the paper's brute
// force (intersect.glsl). The shading is trace.glsl, shared with the vendor's traversal.

// 16x8 pixels per work group, so that each subgroup of 32 traces a 16x2 strip: on the H100
// that is 8-15% faster than 8x4 blocks for primary rays into big meshes, and 22% for
// Sponza in the mirror box (docs/BENCHMARKS.md, "warp shapes"). The host reads the size
// back from the compiled shader (shader_layout.rs).
layout(local_size_x = 16, local_size_y = 8, local_size_z = 1) in;

#include "scene.glsl"
#include "intersect.glsl"
#include "trace.glsl"

void main() {
    // Rows are offset through the push constants, columns through the dispatch base.
    trace_pixel(uvec2(gl_GlobalInvocationID.x, gl_GlobalInvocationID.y + frame.misc.y));
}

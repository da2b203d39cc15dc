#version 450
// The compute tracer: one invocation per pixel, hits found by our BVH or the paper's brute
// force (intersect.glsl). The shading is trace.glsl, shared with the vendor's traversal.

// 32x4 pixels per work group, so that each subgroup of 32 traces one 32-pixel run of a row:
// on the H100 that is 20-27% faster than 8x4-pixel blocks for primary rays into meshes of
// 1M-10M triangles and 10-19% in the mirror box, for 5-10% on the paper's small scenes
// (docs/BENCHMARKS.md, "warp shapes"). The host reads the size back from the compiled
// shader (shader_layout.rs).
layout(local_size_x = 32, local_size_y = 4, local_size_z = 1) in;

#include "scene.glsl"
#include "intersect.glsl"
#include "trace.glsl"

void main() {
    // Rows are offset through the push constants, columns through the dispatch base.
    trace_pixel(uvec2(gl_GlobalInvocationID.x, gl_GlobalInvocationID.y + frame.misc.y));
}

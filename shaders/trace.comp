#version 450
// The compute tracer: one invocation per pixel, hits found by our BVH or the paper's brute
// force (intersect.glsl). The shading is trace.glsl, shared with the vendor's traversal.

layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

#include "scene.glsl"
#include "intersect.glsl"
#include "trace.glsl"

void main() {
    // Rows are offset through the push constants, columns through the dispatch base.
    trace_pixel(uvec2(gl_GlobalInvocationID.x, gl_GlobalInvocationID.y + frame.misc.y));
}

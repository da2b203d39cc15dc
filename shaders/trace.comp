#version 450
// The compute tracer: one invocation per pixel, hits found by our BVH or the paper's brute
// force (intersect.glsl). The shading is trace.glsl, shared with the vendor's traversal.

// 32x4 pixels per work group, so that each subgroup of 32 traces one 32-pixel run of a row:
// on the H100 that is 20-27% faster than 8x4-pixel blocks for primary rays into meshes of
// 1M-10M triangles and 10-19% in the mirror box, for 5-10% on the paper's small scenes
// (docs/BENCHMARKS.md, "warp shapes"). The host reads the size back from the compiled
// shader (shader_layout.rs).
layout(local_size_x = 32, local_size_y = 4, local_size_z = 1) in;
const uvec2 TILE = uvec2(32u, 4u);
const uint TILE_PIXELS = TILE.x * TILE.y;

#include "scene.glsl"
#include "intersect.glsl"
#include "trace.glsl"

// Costliest tiles first (src/gpu/tile_order.rs): the host orders each dispatch's tiles by
// what they cost in the last frame, and each group records what its tile cost this time.
// Both arrays hold one entry per tile of the frame in row order, from `tile_base` on (the
// frame slot's range).
layout(std430, set = 0, binding = 12) readonly buffer TileOrder { uint tile_order[]; };
layout(std430, set = 0, binding = 13) buffer TileCosts { uint tile_costs[]; };

shared uint pixel_costs[TILE_PIXELS];

void main() {
    uint tiles_x = (frame.dims.x + TILE.x - 1u) / TILE.x;
    uint tile_base = floatBitsToUint(frame.cam_up.w);
    // The tile this group would trace in row order: columns come through the dispatch base,
    // rows through the push constants.
    uvec2 tile = uvec2(gl_WorkGroupID.x, gl_WorkGroupID.y + frame.misc.y / TILE.y);
    uint index = tile.y * tiles_x + tile.x;
    // Adaptive sampling's pre-pass stays in row order and records nothing: its cost is not
    // the frame's.
    bool ordered = (frame.dims.w & FLAG_ID_PASS) == 0u;
#ifdef ROW_ORDER
    // The variant for CPU devices (lavapipe), which run a few groups at a time: there the
    // reordering costs cache locality and the barriers below cost more than the order saves.
    trace_pixel(tile * TILE + gl_LocalInvocationID.xy);
#else
    if (ordered) {
        index = tile_order[tile_base + index];
        tile = uvec2(index % tiles_x, index / tiles_x);
    }
    uint cost = trace_pixel(tile * TILE + gl_LocalInvocationID.xy);

    // The tile's total: a tree sum in shared memory.
    uint lane = gl_LocalInvocationIndex;
    pixel_costs[lane] = cost;
    for (uint half_size = TILE_PIXELS / 2u; half_size > 0u; half_size /= 2u) {
        barrier();
        if (lane < half_size) pixel_costs[lane] += pixel_costs[lane + half_size];
    }
    if (ordered && lane == 0u) tile_costs[tile_base + index] = pixel_costs[0];
#endif
}

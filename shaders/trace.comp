#version 450
// The compute tracer: one invocation per pixel, hits found by our BVH or the paper's brute
// force (intersect.glsl). The shading is trace.glsl, shared with the vendor's traversal.

// 32x4 pixels per work group, so that each subgroup of 32 traces one 32-pixel run of a row:
// on the H100 that is 20-27% faster than 8x4-pixel blocks for primary rays into meshes of
// 1M-10M triangles and 10-19% in the mirror box, for 5-10% on the paper's small scenes
// (docs/BENCHMARKS.md, "warp shapes"). Frames that walk many instances trace 8x4 blocks
// of the same tile instead (tile_pixel). The host reads the size back from the compiled
// shader (shader_layout.rs).
layout(local_size_x = 32, local_size_y = 4, local_size_z = 1) in;
const uvec2 TILE = uvec2(32u, 4u);

// The kernels that leave out the AO view (src/gpu/shader_compile.rs: CORE_ONLY, WIDE_ONLY).
#if defined(CORE_ONLY) || defined(WIDE_ONLY)
#define NO_AO_VIEW
#endif

#include "scene.glsl"
#include "intersect.glsl"
#include "trace.glsl"

// Costliest tiles first (src/gpu/tile_order.rs): the host orders each dispatch's tiles by
// what they cost in the last frame, and each group records what its tile cost this time.
// From `tile_base` on (the frame slot's range), the order holds one entry per tile of the
// frame in row order, the costs one per subgroup of each tile: the cost of its middle
// lane's pixel. A sample, not a sum: summing a group's pixels would need a barrier
// (no subgroup arithmetic or atomics in naga's GLSL), which cost the H100 0.04 ms a frame.
layout(std430, set = 0, binding = 12) readonly buffer TileOrder { uint tile_order[]; };
layout(std430, set = 0, binding = 13) buffer TileCosts { uint tile_costs[]; };

// The pixel of the group's tile that the lane at `lane` traces: its place in the rows
// above, or where the walk visits many instances (FLAG_WARP_BLOCKS, the same for every
// lane), in an 8x4 block (subgroup y the block at x = 8y). A row of 32 pixels crosses
// several small instances; a block's lanes walk to and enter fewer of them (on the H200
// the model series 5-13% faster from 4 copies on, and the fields of 10,000 knots 7-10%).
uvec2 tile_pixel(uvec3 lane) {
#ifndef ONE_INSTANCE
    if ((frame.dims.w & FLAG_WARP_BLOCKS) != 0u) return uvec2(lane.y * 8u + lane.x % 8u, lane.x / 8u);
#endif
    return lane.xy;
}

void main() {
    // A band finer than a group: this group's other lanes trace and record nothing.
    if (!in_band(gl_LocalInvocationIndex)) return;
    uint tiles_x = (frame.dims.x + TILE.x - 1u) / TILE.x;
    uint tile_base = floatBitsToUint(frame.cam_up.w);
    // The tile this group would trace in row order: columns come through the dispatch base,
    // rows through the push constants.
    uvec2 tile = uvec2(gl_WorkGroupID.x, gl_WorkGroupID.y + frame.misc.y / TILE.y);
    uint index = tile.y * tiles_x + tile.x;
#ifdef ROW_ORDER
    // The variant for CPU devices (lavapipe), which run a few groups at a time: there the
    // reordering costs more cache locality than it saves.
    trace_pixel(tile * TILE + tile_pixel(gl_LocalInvocationID));
#else
    // Adaptive sampling's pre-pass stays in row order and records nothing: its cost is not
    // the frame's.
    bool ordered = (frame.dims.w & FLAG_ID_PASS) == 0u;
    if (ordered) {
        index = tile_order[tile_base + index];
        tile = uvec2(index % tiles_x, index / tiles_x);
    }
    uint cost = trace_pixel(tile * TILE + tile_pixel(gl_LocalInvocationID));
    if (ordered && gl_LocalInvocationID.x == TILE.x / 2u) {
        tile_costs[(tile_base + index) * TILE.y + gl_LocalInvocationID.y] = cost;
    }
#endif
}

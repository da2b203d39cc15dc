// What every kernel of the device BVH build shares (src/gpu/bvh_build.rs): its buffers and
// push constants. The build is a linear BVH (Karras 2012): triangles sorted by the Morton
// code of their centroids, runs of `leaf_size` of them as leaves, the tree over the leaves
// read off the sorted codes, boxes filled in from the leaves up. Compiled by glslang: the
// refit needs atomics and coherent memory, which naga's GLSL front end does not take.
#include "contract.glsl"

// Digits of the radix sort: 4 bits, so a work group ranks its items with 16 counters a
// thread (stable, which a least-significant-digit sort needs).
#define RADIX_BITS 4u
#define RADIX 16u
// Threads of a radix work group and items each thread takes: a block of 2048 items.
#define SORT_THREADS 128u
#define SORT_ITEMS 16u
#define SORT_BLOCK (SORT_THREADS * SORT_ITEMS)

layout(push_constant) uniform Build {
    vec4 lo;          // xyz: the mesh box's min corner
    vec4 cells;       // xyz: Morton cells per unit along each axis (1024 / extent)
    uint count;       // the mesh's triangles
    uint tri_base;    // its first slot in the scene's triangle and hit-record buffers
    uint node_base;   // its first node in the scene's node buffer
    uint leaf_size;   // triangles a leaf (the last leaf may hold fewer)
    uint shift;       // a radix pass: its digit's lowest bit
    uint flip;        // a radix pass: 0 sorts from the A arrays into B, 1 from B into A
    uint blocks;      // a radix pass: blocks of SORT_BLOCK items
    uint leaves;      // leaves of the tree: ceil(count / leaf_size)
    // The collapse into the wide tree (`collapse.comp`):
    uint wide_word;   // where the mesh's wide nodes start in `node_words`
    uint wide_limit;  // wide nodes reserved for it
    uint bin_base;    // where its binary nodes start in `bin_words`
    uint patch_binary;  // 1: the binary tree is kept, its leaves pointed at the wide order
    uint level;       // the collapse's level: its items are in queue (level & 1)
} pc;

// The scene's triangles as 32-bit words, 10 a triangle (`GpuTriangle`: v0, e1, e2, prim).
layout(std430, set = 0, binding = 0) buffer Triangles { uint tri_words[]; };
// The scene's hit records (`GpuTriangleShading`), in the order of the triangles.
layout(std430, set = 0, binding = 1) buffer Shading { uvec4 shading[]; };
// The scene's binary nodes as 32-bit words, 16 a node (`BvhNode`: left min, index, max,
// count, then the right child's). Coherent: the refit reads boxes other threads wrote.
layout(std430, set = 0, binding = 2) coherent buffer Nodes { uint node_words[]; };
// The mesh's triangles and hit records in file order, copied out before the reordering.
layout(std430, set = 0, binding = 3) readonly buffer SourceTriangles { uint src_words[]; };
layout(std430, set = 0, binding = 4) readonly buffer SourceShading { uvec4 src_shading[]; };
// Keys and values of the sort: A keys, A values, B keys, B values, `count` words each.
layout(std430, set = 0, binding = 5) buffer Sort { uint sort_words[]; };
// Each block's digit counts, digit-major (RADIX * blocks), then scanned in place.
layout(std430, set = 0, binding = 6) buffer Histogram { uint histogram[]; };
// The tree's bookkeeping: each leaf's parent, then each inner node's (bit 31: right
// child), then each inner node's arrivals in the refit, then the height of each inner
// node's two children (a leaf's is 0).
layout(std430, set = 0, binding = 7) coherent buffer Tree { uint tree_words[]; };
// The collapse: the binary tree it reads (and patches), and its work queues (`collapse.comp`).
layout(std430, set = 0, binding = 8) buffer BinaryNodes { uint bin_words[]; };
layout(std430, set = 0, binding = 9) buffer Queue { uint queue_words[]; };

// Where the tree's bookkeeping arrays start in `tree_words`.
uint inner_parents() { return pc.leaves; }
uint arrivals() { return 2u * pc.leaves - 1u; }
uint child_heights() { return 3u * pc.leaves - 2u; }

uint key_a(uint i) { return sort_words[i]; }
uint value_a(uint i) { return sort_words[pc.count + i]; }

// The work group's index in a dispatch of more groups than one dimension may hold
// (65,535 is all a device must allow): the host spreads them over x and y.
uint flat_group() { return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x; }

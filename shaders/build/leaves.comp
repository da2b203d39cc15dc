#version 460
// The device BVH build, step 4: each leaf's triangles and hit records moved into sorted
// order, its box made from its corners, and the boxes carried up the tree: a node's box is
// written into its parent's record, and the second of the two children to arrive (an
// atomic count) goes on up with the union of both, and the subtree's height (which the
// collapse into the wide tree reads).
#include "common.glsl"

layout(local_size_x = 256) in;

// Record `lo`..`hi` as child `side` of node `node`.
void set_box(uint node, uint side, vec3 lo, vec3 hi) {
    uint w = 16u * (pc.node_base + node) + 8u * side;
    node_words[w] = floatBitsToUint(lo.x);
    node_words[w + 1u] = floatBitsToUint(lo.y);
    node_words[w + 2u] = floatBitsToUint(lo.z);
    node_words[w + 4u] = floatBitsToUint(hi.x);
    node_words[w + 5u] = floatBitsToUint(hi.y);
    node_words[w + 6u] = floatBitsToUint(hi.z);
}

vec3 box_corner(uint w) {
    return uintBitsToFloat(uvec3(node_words[w], node_words[w + 1u], node_words[w + 2u]));
}

void main() {
    uint leaf = flat_group() * 256u + gl_LocalInvocationID.x;
    if (leaf >= pc.leaves) {
        return;
    }
    uint first = leaf * pc.leaf_size;
    uint end = min(first + pc.leaf_size, pc.count);
    vec3 lo = vec3(uintBitsToFloat(0x7f800000u));
    vec3 hi = -lo;
    for (uint j = first; j < end; j++) {
        uint from = 10u * value_a(j);
        uint to = 10u * (pc.tri_base + j);
        for (uint k = 0u; k < 10u; k++) {
            tri_words[to + k] = src_words[from + k];
        }
        shading[pc.tri_base + j] = src_shading[value_a(j)];
        vec3 v0 = uintBitsToFloat(uvec3(src_words[from], src_words[from + 1u], src_words[from + 2u]));
        vec3 e1 = uintBitsToFloat(uvec3(src_words[from + 3u], src_words[from + 4u], src_words[from + 5u]));
        vec3 e2 = uintBitsToFloat(uvec3(src_words[from + 6u], src_words[from + 7u], src_words[from + 8u]));
        vec3 v1 = v0 + e1;
        vec3 v2 = v0 + e2;
        lo = min(lo, min(v0, min(v1, v2)));
        hi = max(hi, max(v0, max(v1, v2)));
    }
    // The traversal tests v0 + u e1 + v e2, whose corners the sums above may round inward
    // by half an ulp: a box an ulp wider holds them.
    vec3 pad = max(abs(lo), abs(hi)) * 2.4e-7;
    lo -= pad;
    hi += pad;
    uint at = tree_words[leaf];
    uint height = 0u;  // of the subtree carried up: a leaf's is 0
    while (true) {
        uint node = at & 0x7fffffffu;
        uint side = at >> 31u;
        set_box(node, side, lo, hi);
        tree_words[child_heights() + 2u * node + side] = height;
        memoryBarrierBuffer();
        if (atomicAdd(tree_words[arrivals() + node], 1u) == 0u) {
            return;  // the sibling carries the union up
        }
        memoryBarrierBuffer();
        uint w = 16u * (pc.node_base + node);
        lo = min(box_corner(w), box_corner(w + 8u));
        hi = max(box_corner(w + 4u), box_corner(w + 12u));
        uint h = child_heights() + 2u * node;
        height = 1u + max(tree_words[h], tree_words[h + 1u]);
        if (node == 0u) {
            return;
        }
        at = tree_words[inner_parents() + node];
    }
}

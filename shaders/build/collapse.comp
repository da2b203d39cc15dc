#version 460
// The device BVH build, the wide tree: the binary tree collapsed into the compressed
// eight-wide layout (`WideNode`, src/bvh/wide/mod.rs), one level of wide nodes a dispatch.
// An item is a binary node to become a wide node: it takes the node's two children and
// opens the inner child of the largest area while it has fewer than eight (Ylitie et al.
// 2017's greedy collapse), places its leaves' triangles side by side (an atomic count over
// the mesh), takes a run of wide nodes for its inner children and queues them for the next
// level. An opening is taken only while the traversal's stack stays within WIDE_STACK_SIZE
// on every path below: the pending entries along the path so far, the node's own, and the
// binary height below each inner child (what collapsing it two by two would add).
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#include "common.glsl"

layout(local_size_x = 64) in;

// Entries of a path's stack the tree may need: the traversal's stack less the root's.
#define NEED_LIMIT (WIDE_STACK_SIZE - 1u)
// Words of the queue's header: the two queues' counts, wide nodes and triangles placed,
// an overflow flag, the indirect dispatch's arguments (words 8-10); items follow.
#define HEADER 16u

struct Child {
    vec3 lo;
    vec3 hi;
    uint index;   // inner: the binary node; leaf: its first triangle (binary order)
    uint count;   // 0 for an inner node, else the leaf's triangles
    uint parent;  // the binary node that holds it, and on which side (bit 31)
    uint merged;  // a small subtree taken as one leaf: its binary node (else EMPTY)
    uint height;  // its binary height (a leaf's is 0)
};

// The binary height of inner node `node`: 1 + its taller child's (a leaf's is 0).
uint height_below(uint node) {
    uint h = child_heights() + 2u * node;
    return 1u + max(tree_words[h], tree_words[h + 1u]);
}

Child child_of(uint node, uint side) {
    uint w = 16u * (pc.bin_base + node) + 8u * side;
    Child c;
    c.lo = uintBitsToFloat(uvec3(bin_words[w], bin_words[w + 1u], bin_words[w + 2u]));
    c.hi = uintBitsToFloat(uvec3(bin_words[w + 4u], bin_words[w + 5u], bin_words[w + 6u]));
    c.index = bin_words[w + 3u];
    c.count = bin_words[w + 7u];
    c.parent = node | (side << 31u);
    c.merged = EMPTY;
    c.height = c.count == 0u && c.index != EMPTY ? height_below(c.index) : 0u;
    return c;
}

// An inner child of at most MAX_LEAF triangles (at most three leaves: two levels) as one
// leaf slot, as the CPU's collapse merges them: a subtree's triangles lie side by side.
#define MAX_LEAF 3u
Child merged(Child c) {
    uint first = EMPTY;
    uint total = 0u;
    uint stack[2];
    uint depth = 0u;
    stack[depth++] = c.index;
    while (depth > 0u && total <= MAX_LEAF) {
        uint b = stack[--depth];
        for (uint side = 0u; side < 2u; side++) {
            Child x = child_of(b, side);
            if (x.count != 0u) {
                total += x.count;
                first = min(first, x.index);
            } else if (x.index != EMPTY) {
                if (depth == 2u) {
                    return c;  // deeper than a subtree of three leaves
                }
                stack[depth++] = x.index;
            }
        }
    }
    if (total > MAX_LEAF) {
        return c;
    }
    Child leaf = c;
    leaf.merged = c.index;
    leaf.index = first;
    leaf.count = total;
    return leaf;
}

// Point the binary leaves under `root` (a merged subtree whose first triangle was `first`)
// at their triangles' new place, `moved_to` onwards.
void patch_merged(uint root, uint first, uint moved_to) {
    uint stack[2];
    uint depth = 0u;
    stack[depth++] = root;
    while (depth > 0u) {
        uint b = stack[--depth];
        for (uint side = 0u; side < 2u; side++) {
            uint w = 16u * (pc.bin_base + b) + 8u * side;
            if (bin_words[w + 7u] != 0u) {
                bin_words[w + 3u] = moved_to + (bin_words[w + 3u] - first);
            } else if (bin_words[w + 3u] != EMPTY && depth < 2u) {
                stack[depth++] = bin_words[w + 3u];
            }
        }
    }
}

float area(Child c) {
    vec3 d = max(c.hi - c.lo, vec3(0.0));
    return d.x * d.y + d.y * d.z + d.z * d.x;
}

// The biased exponent of the scale spanning lo..hi in 255 steps (as `exponent` in
// src/bvh/wide/collapse.rs): the smallest whose 255 steps, decoded in f32, reach hi.
uint exponent(float lo, float hi) {
    float extent = (hi - lo) / 255.0;
    int biased = 1;
    if (extent > 0.0 && !isinf(extent)) {
        biased = clamp(int(ceil(log2(extent))) + 127, 1, 254);
    }
    while (biased > 1 && lo + 255.0 * uintBitsToFloat(uint(biased - 1) << 23u) >= hi) {
        biased--;
    }
    while (biased < 254 && lo + 255.0 * uintBitsToFloat(uint(biased) << 23u) < hi) {
        biased++;
    }
    return uint(biased);
}

void main() {
    uint in_queue = pc.level & 1u;
    uint i = flat_group() * 64u + gl_LocalInvocationID.x;
    if (i >= queue_words[in_queue]) {
        return;
    }
    uint capacity = pc.wide_limit;
    uint item = HEADER + in_queue * 3u * capacity + 3u * i;
    uint node = queue_words[item];
    uint wide = queue_words[item + 1u];
    uint need = queue_words[item + 2u];

    Child children[8];
    children[0] = child_of(node, 0u);
    children[1] = child_of(node, 1u);
    // A root over one leaf has an absent right child.
    uint k = children[1].index == EMPTY && children[1].count == 0u ? 1u : 2u;
    // Inner children whose opening would take the stack past its bound.
    uint closed = 0u;
    while (k < 8u) {
        // The inner child of the largest area not closed.
        int best = -1;
        float best_area = -1.0;
        for (uint c = 0u; c < k; c++) {
            bool open = children[c].count == 0u && (closed & (1u << c)) == 0u;
            if (open && area(children[c]) > best_area) {
                best = int(c);
                best_area = area(children[c]);
            }
        }
        if (best < 0) {
            break;
        }
        Child l = child_of(children[best].index, 0u);
        Child r = child_of(children[best].index, 1u);
        uint below = max(l.height, r.height);
        for (uint o = 0u; o < k; o++) {
            if (o != uint(best)) {
                below = max(below, children[o].height);
            }
        }
        if (need + k + below > NEED_LIMIT) {
            closed |= 1u << uint(best);
            continue;
        }
        children[best] = l;
        children[k] = r;
        k++;
    }

    for (uint c = 0u; c < k; c++) {
        if (children[c].count == 0u && children[c].height <= 2u) {
            children[c] = merged(children[c]);
        }
    }

    // The node's frame: origin at its box's minimum, per axis a power-of-two scale.
    vec3 lo = children[0].lo;
    vec3 hi = children[0].hi;
    uint inner = 0u;
    uint leaf_triangles = 0u;
    for (uint c = 1u; c < k; c++) {
        lo = min(lo, children[c].lo);
        hi = max(hi, children[c].hi);
    }
    for (uint c = 0u; c < k; c++) {
        inner += children[c].count == 0u ? 1u : 0u;
        leaf_triangles += children[c].count;
    }
    uvec3 e = uvec3(exponent(lo.x, hi.x), exponent(lo.y, hi.y), exponent(lo.z, hi.z));
    vec3 scale = uintBitsToFloat(e << 23u);

    // Wide nodes for the inner children, places for the leaves' triangles and queue slots
    // for the inner children, taken for the whole subgroup by one atomic each: one a
    // thread made 15.7M atomics on each counter at 100M triangles.
    uint out_queue = 1u - in_queue;
    uvec3 wanted = uvec3(inner, leaf_triangles, inner);
    uvec3 before = subgroupExclusiveAdd(wanted);
    uvec3 total = subgroupAdd(wanted);
    uvec3 taken = uvec3(0u);
    if (subgroupElect()) {
        taken.x = atomicAdd(queue_words[2], total.x);
        taken.y = atomicAdd(queue_words[3], total.y);
        taken.z = atomicAdd(queue_words[out_queue], total.z);
    }
    taken = subgroupBroadcastFirst(taken) + before;
    uint child_base = taken.x;
    uint triangle_base = taken.y;
    uint queued = taken.z;
    if (child_base + inner > capacity) {
        queue_words[4] = 1u;  // more wide nodes than reserved: the host refuses the tree
        return;
    }

    uint meta[8];
    uint qlo[3][8];
    uint qhi[3][8];
    uint imask = 0u;
    uint next_inner = 0u;
    uint offset = 0u;
    for (uint s = 0u; s < 8u; s++) {
        meta[s] = 0u;
        qlo[0][s] = 255u; qlo[1][s] = 255u; qlo[2][s] = 255u;
        qhi[0][s] = 0u; qhi[1][s] = 0u; qhi[2][s] = 0u;
        if (s >= k) {
            continue;
        }
        Child c = children[s];
        // The slot's box rounded outwards, so that the decoded box holds the child.
        for (uint a = 0u; a < 3u; a++) {
            float p = lo[a];
            float step = scale[a];
            float q_lo = clamp(floor((c.lo[a] - p) / step), 0.0, 255.0);
            while (q_lo > 0.0 && p + q_lo * step > c.lo[a]) {
                q_lo -= 1.0;
            }
            float q_hi = clamp(ceil((c.hi[a] - p) / step), 0.0, 255.0);
            while (q_hi < 255.0 && p + q_hi * step < c.hi[a]) {
                q_hi += 1.0;
            }
            qlo[a][s] = uint(q_lo);
            qhi[a][s] = uint(q_hi);
        }
        if (c.count == 0u) {
            imask |= 1u << s;
            meta[s] = (1u << 5u) | (24u + s);
            uint to = out_queue * 3u * capacity + 3u * (queued + next_inner);
            queue_words[HEADER + to] = c.index;
            queue_words[HEADER + to + 1u] = child_base + next_inner;
            queue_words[HEADER + to + 2u] = need + k - 1u;
            next_inner++;
        } else {
            // The leaf's triangles, moved to their place in the wide tree's order.
            uint first = triangle_base + offset;
            for (uint t = 0u; t < c.count; t++) {
                uint from = 10u * (c.index + t);
                uint to = 10u * (pc.tri_base + first + t);
                for (uint w = 0u; w < 10u; w++) {
                    tri_words[to + w] = src_words[from + w];
                }
                shading[pc.tri_base + first + t] = src_shading[c.index + t];
            }
            if (pc.patch_binary != 0u) {
                // The binary tree reads its leaves where they now lie.
                if (c.merged != EMPTY) {
                    patch_merged(c.merged, c.index, first);
                } else {
                    uint side = c.parent >> 31u;
                    bin_words[16u * (pc.bin_base + (c.parent & 0x7fffffffu)) + 8u * side + 3u] = first;
                }
            }
            meta[s] = (((1u << c.count) - 1u) << 5u) | offset;
            offset += c.count;
        }
    }

    uint w = pc.wide_word + 20u * wide;
    node_words[w] = floatBitsToUint(lo.x);
    node_words[w + 1u] = floatBitsToUint(lo.y);
    node_words[w + 2u] = floatBitsToUint(lo.z);
    node_words[w + 3u] = e.x | (e.y << 8u) | (e.z << 16u) | (imask << 24u);
    node_words[w + 4u] = child_base;
    node_words[w + 5u] = triangle_base;
    node_words[w + 6u] = meta[0] | (meta[1] << 8u) | (meta[2] << 16u) | (meta[3] << 24u);
    node_words[w + 7u] = meta[4] | (meta[5] << 8u) | (meta[6] << 16u) | (meta[7] << 24u);
    for (uint a = 0u; a < 3u; a++) {
        node_words[w + 8u + 2u * a] = qlo[a][0] | (qlo[a][1] << 8u) | (qlo[a][2] << 16u) | (qlo[a][3] << 24u);
        node_words[w + 9u + 2u * a] = qlo[a][4] | (qlo[a][5] << 8u) | (qlo[a][6] << 16u) | (qlo[a][7] << 24u);
        node_words[w + 14u + 2u * a] = qhi[a][0] | (qhi[a][1] << 8u) | (qhi[a][2] << 16u) | (qhi[a][3] << 24u);
        node_words[w + 15u + 2u * a] = qhi[a][4] | (qhi[a][5] << 8u) | (qhi[a][6] << 16u) | (qhi[a][7] << 24u);
    }
}

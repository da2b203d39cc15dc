#version 460
// The device BVH build, step 3: the tree over the leaves, read off their sorted Morton
// codes (Karras 2012, "Maximizing parallelism in the construction of BVHs, octrees and
// k-d trees"). Inner node i covers a range of leaves starting or ending at leaf i; it
// splits where the codes' common prefix gets longer. Codes that tie are told apart by the
// leaf's index, so the tree's depth stays within 30 + log2(leaves) + 1 nodes. Node 0 is
// the root, as in every tree of ours. Boxes are filled in by the next step.
#include "common.glsl"

layout(local_size_x = 256) in;

// A leaf's key: its first triangle's code.
uint leaf_key(int leaf) {
    return key_a(uint(leaf) * pc.leaf_size);
}

// The common prefix of leaves i and j: -1 outside the leaves, past 32 for equal codes.
int delta(int i, int j) {
    if (j < 0 || j >= int(pc.leaves)) {
        return -1;
    }
    uint a = leaf_key(i);
    uint b = leaf_key(j);
    if (a == b) {
        return 32 + 31 - findMSB(uint(i ^ j));
    }
    return 31 - findMSB(a ^ b);
}

// Write child `side` (0 left, 1 right) of node `node`: leaf or inner node `index`, and
// note the node as the child's parent.
void set_child(uint node, uint side, uint index, bool leaf) {
    uint w = 16u * (pc.node_base + node) + 8u * side;
    if (leaf) {
        uint first = index * pc.leaf_size;
        node_words[w + 3u] = first;
        node_words[w + 7u] = min(pc.leaf_size, pc.count - first);
        tree_words[index] = node | (side << 31u);
    } else {
        node_words[w + 3u] = index;
        node_words[w + 7u] = 0u;
        tree_words[inner_parents() + index] = node | (side << 31u);
    }
}

void main() {
    int i = int(flat_group() * 256u + gl_LocalInvocationID.x);
    if (i >= int(pc.leaves) - 1) {
        return;
    }
    // The direction the node's range grows in from leaf i.
    int d = delta(i, i + 1) - delta(i, i - 1) >= 0 ? 1 : -1;
    int shortest = delta(i, i - d);
    int reach = 2;
    while (delta(i, i + reach * d) > shortest) {
        reach *= 2;
    }
    int span = 0;
    for (int t = reach / 2; t >= 1; t /= 2) {
        if (delta(i, i + (span + t) * d) > shortest) {
            span += t;
        }
    }
    int j = i + span * d;
    int prefix = delta(i, j);
    // Binary search for the split: the last leaf sharing more than `prefix` with leaf i.
    int split = 0;
    int div = 2;
    while (true) {
        int t = (span + div - 1) / div;
        if (delta(i, i + (split + t) * d) > prefix) {
            split += t;
        }
        if (t <= 1) {
            break;
        }
        div *= 2;
    }
    int gamma = i + split * d + min(d, 0);
    set_child(uint(i), 0u, uint(gamma), min(i, j) == gamma);
    set_child(uint(i), 1u, uint(gamma + 1), max(i, j) == gamma + 1);
}

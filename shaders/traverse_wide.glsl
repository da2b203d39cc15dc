// Closest-hit traversal of the compressed wide BVH (src/bvh/wide/, Ylitie, Karras, Laine
// 2017): eight quantized child boxes per 80-byte node, children visited in the ray's
// octant order, a stack of node groups. Mirrors src/bvh/wide/traverse.rs step for step.

// The BVH node buffer seen as 16-byte words: the wide nodes follow the binary ones, five
// words each (an instance's first one in `bounds_min.w`). Words of a node:
//   0: origin xyz (float bits), w: exponents x, y, z (bytes 0-2), imask (byte 3)
//   1: child base, triangle base, meta of slots 0-3, meta of slots 4-7
//   2: quantized lo.x (slots 0-3, 4-7), lo.y (0-3, 4-7)
//   3: lo.z, hi.x
//   4: hi.y, hi.z
layout(std430, set = 0, binding = 14) readonly buffer WideNodes { uvec4 wide_nodes[]; };

// Byte `s` (0-7) of the eight bytes in `lo`, `hi`.
float slot_byte(uint lo, uint hi, uint s) {
    uint word = s < 4u ? lo : hi;
    return float((word >> ((s & 3u) * 8u)) & 0xffu);
}

void traverse_wide(vec3 o, vec3 d, uint word_base, uint tri_base, inout Hit hit, inout uvec2 cost) {
    vec3 inv_d = safe_inverse(d);
    uint octant = (d.x < 0.0 ? 1u : 0u) | (d.y < 0.0 ? 2u : 0u) | (d.z < 0.0 ? 4u : 0u);
    // A node group: x = the first sibling's node index, y = pending hit slots (bits 0-7,
    // by slot ^ octant) and the parent's imask (bits 8-15). The root: slot 0 of one.
    uvec2 stack[STACK_SIZE];
    uint sp = 0u;
    uvec2 group = uvec2(0u, (1u << octant) | (1u << 8u));
    while (true) {
        if ((group.y & 0xffu) == 0u) {
            if (sp == 0u) break;
            sp -= 1u;
            group = stack[sp];
        }
        uint bit = uint(findLSB(group.y & 0xffu));
        group.y &= ~(1u << bit);
        uint slot = bit ^ octant;
        uint imask = group.y >> 8u;
        uint index = group.x + uint(bitCount(imask & ((1u << slot) - 1u)));
        if ((group.y & 0xffu) != 0u) {
            stack[sp] = group;
            sp += 1u;
        }

        uint at = word_base + index * 5u;
        uvec4 w0 = wide_nodes[at];
        uvec4 w1 = wide_nodes[at + 1u];
        uvec4 w2 = wide_nodes[at + 2u];
        uvec4 w3 = wide_nodes[at + 3u];
        uvec4 w4 = wide_nodes[at + 4u];
        cost.x += 1u;
        vec3 origin = uintBitsToFloat(w0.xyz);
        // 2^(e - 127) from the biased exponent byte, exactly as the host's f32::from_bits.
        vec3 scale = uintBitsToFloat(uvec3(w0.w & 0xffu, (w0.w >> 8u) & 0xffu, (w0.w >> 16u) & 0xffu) << 23u);
        uint node_imask = w0.w >> 24u;

        uint inner_hits = 0u;
        uint leaf_bits = 0u;
        for (uint s = 0u; s < 8u; s++) {
            uint meta = ((s < 4u ? w1.z : w1.w) >> ((s & 3u) * 8u)) & 0xffu;
            if (meta == 0u) continue;
            vec3 qlo = vec3(slot_byte(w2.x, w2.y, s), slot_byte(w2.z, w2.w, s), slot_byte(w3.x, w3.y, s));
            vec3 qhi = vec3(slot_byte(w3.z, w3.w, s), slot_byte(w4.x, w4.y, s), slot_byte(w4.z, w4.w, s));
            if (slab(origin + qlo * scale, origin + qhi * scale, o, inv_d, hit.t) == INF) continue;
            if ((node_imask & (1u << s)) != 0u) {
                inner_hits |= 1u << (s ^ octant);
            } else {
                leaf_bits |= (meta >> 5u) << (meta & 31u);
            }
        }
        // This node's leaves now, in slot order.
        uint first = tri_base + w1.y;
        while (leaf_bits != 0u) {
            uint offset = uint(findLSB(leaf_bits));
            leaf_bits &= leaf_bits - 1u;
            intersect_triangle(o, d, first + offset, hit);
            cost.y += 1u;
        }
        group = uvec2(w1.x, inner_hits | (node_imask << 8u));
    }
}

// Closest-hit traversal of the compressed wide BVH (src/bvh/wide/, Ylitie, Karras, Laine
// 2017): eight quantized child boxes per 80-byte node, children visited in the ray's
// octant order, a stack of node groups. Mirrors src/bvh/wide/traverse.rs step for step,
// except that the boxes are tested as the paper does, in the node's grid with the grid
// folded into the ray and four slots at a time (13-28% faster on the H100 than decoding
// each box; docs/BENCHMARKS.md, "Fifteenth session"), where the CPU tests the decoded
// boxes: the two may round a ray that touches a box's face differently.

// The BVH node buffer seen as 16-byte words: the wide nodes follow the binary ones, five
// words each (an instance's first one in `bounds_min.w`). Words of a node:
//   0: origin xyz (float bits), w: exponents x, y, z (bytes 0-2), imask (byte 3)
//   1: child base, triangle base, meta of slots 0-3, meta of slots 4-7
//   2: quantized lo.x (slots 0-3, 4-7), lo.y (0-3, 4-7)
//   3: lo.z, hi.x
//   4: hi.y, hi.z
layout(std430, set = 0, binding = 14) readonly buffer WideNodes { uvec4 wide_nodes[]; };

// The four bytes of `w` as floats (slot 0 of the four in the lowest byte).
vec4 slot_bytes(uint w) {
    return vec4(float(w & 0xffu), float((w >> 8u) & 0xffu), float((w >> 16u) & 0xffu), float(w >> 24u));
}

// Which of four slots the ray meets before t_max: the slab test of slab() on boxes in a
// node's grid, t = q * a + b per axis, with each axis's near and far planes chosen once
// per node by the ray's direction (nx..fz: the quantized coordinates of those planes).
uint slots_hit(uint nx, uint ny, uint nz, uint fx, uint fy, uint fz, vec3 a, vec3 b, float t_max) {
    vec4 enter = max(max(slot_bytes(nx) * a.x + b.x, slot_bytes(ny) * a.y + b.y), max(slot_bytes(nz) * a.z + b.z, vec4(0.0)));
    vec4 exit = min(min(slot_bytes(fx) * a.x + b.x, slot_bytes(fy) * a.y + b.y), min(slot_bytes(fz) * a.z + b.z, vec4(t_max))) * 1.0000004;
    bvec4 hit = lessThanEqual(enter, exit);
    return (hit.x ? 1u : 0u) | (hit.y ? 2u : 0u) | (hit.z ? 4u : 0u) | (hit.w ? 8u : 0u);
}

// The slots of four whose meta byte is not 0 (not empty).
uint slots_used(uint meta) {
    return ((meta & 0xffu) != 0u ? 1u : 0u) | ((meta & 0xff00u) != 0u ? 2u : 0u) | ((meta & 0xff0000u) != 0u ? 4u : 0u) | ((meta & 0xff000000u) != 0u ? 8u : 0u);
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
        // The node's frame folded into the ray: a box plane at grid coordinate q is met at
        // t = q * a + b. A ray going down an axis meets the hi plane first.
        vec3 a = scale * inv_d;
        vec3 b = (origin - o) * inv_d;
        uvec2 lo_x = w2.xy, lo_y = w2.zw, lo_z = w3.xy, hi_x = w3.zw, hi_y = w4.xy, hi_z = w4.zw;
        uvec2 near_x = inv_d.x >= 0.0 ? lo_x : hi_x, far_x = inv_d.x >= 0.0 ? hi_x : lo_x;
        uvec2 near_y = inv_d.y >= 0.0 ? lo_y : hi_y, far_y = inv_d.y >= 0.0 ? hi_y : lo_y;
        uvec2 near_z = inv_d.z >= 0.0 ? lo_z : hi_z, far_z = inv_d.z >= 0.0 ? hi_z : lo_z;
        uint hits = slots_hit(near_x.x, near_y.x, near_z.x, far_x.x, far_y.x, far_z.x, a, b, hit.t)
                  | (slots_hit(near_x.y, near_y.y, near_z.y, far_x.y, far_y.y, far_z.y, a, b, hit.t) << 4u);
        hits &= slots_used(w1.z) | (slots_used(w1.w) << 4u);

        // Inner children hit, each at bit slot ^ octant: the XOR moves bits by 1, 2 and 4.
        uint inner_hits = hits & node_imask;
        if ((octant & 1u) != 0u) inner_hits = ((inner_hits & 0x55u) << 1u) | ((inner_hits & 0xaau) >> 1u);
        if ((octant & 2u) != 0u) inner_hits = ((inner_hits & 0x33u) << 2u) | ((inner_hits & 0xccu) >> 2u);
        if ((octant & 4u) != 0u) inner_hits = ((inner_hits & 0x0fu) << 4u) | ((inner_hits & 0xf0u) >> 4u);
        uint leaf_hits = hits & ~node_imask;
        uint leaf_bits = 0u;
        while (leaf_hits != 0u) {
            uint s = uint(findLSB(leaf_hits));
            leaf_hits &= leaf_hits - 1u;
            uint meta = ((s < 4u ? w1.z : w1.w) >> ((s & 3u) * 8u)) & 0xffu;
            leaf_bits |= (meta >> 5u) << (meta & 31u);
        }
        // This node's leaves now, in slot order; the first two triangles are loaded before
        // either is tested, so that their fetches overlap (as test_leaves does).
        uint first = tri_base + w1.y;
        if (leaf_bits != 0u) {
            uint k0 = first + uint(findLSB(leaf_bits));
            leaf_bits &= leaf_bits - 1u;
            bool two = leaf_bits != 0u;
            uint k1 = two ? first + uint(findLSB(leaf_bits)) : k0;
            leaf_bits &= leaf_bits - 1u;
            Triangle t0 = load_triangle(k0);
            Triangle t1 = load_triangle(k1);
            intersect_loaded(o, d, t0, k0, hit);
            if (two) intersect_loaded(o, d, t1, k1, hit);
            cost.y += two ? 2u : 1u;
        }
        while (leaf_bits != 0u) {
            uint offset = uint(findLSB(leaf_bits));
            leaf_bits &= leaf_bits - 1u;
            intersect_triangle(o, d, first + offset, hit);
            cost.y += 1u;
        }
        group = uvec2(w1.x, inner_hits | (node_imask << 8u));
    }
}

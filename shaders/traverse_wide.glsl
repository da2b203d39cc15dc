// Closest-hit traversal of the compressed wide BVH (src/bvh/wide/, Ylitie, Karras, Laine
// 2017): eight quantized child boxes per 80-byte node. Mirrors src/bvh/wide/traverse.rs
// step for step: the slots a visit hits are ordered by the distance at which the ray
// enters them, the nearest visited next and the others pushed with that distance, and a
// pending child entered beyond the closest hit found since is dropped unread. The boxes are
// tested as the paper does, in the node's grid with the grid folded into the ray and four
// slots at a time, where the CPU tests the decoded boxes: the two may round a ray that
// touches a box's face differently.

layout(std430, set = 0, binding = 14) readonly buffer WideNodes { uvec4 wide_nodes[]; };

// The four bytes of `w` as floats (slot 0 of the four in the lowest byte).
vec4 slot_bytes(uint w) {
    return vec4(float(w & 0xffu), float((w >> 8u) & 0xffu), float((w >> 16u) & 0xffu), float(w >> 24u));
}

// The sort keys of four slots (see sort_key in src/bvh/wide/traverse.rs): the distance at
// which the ray enters each box, its low three bits replaced by the slot (`slots`: the four
// slot numbers), or 0 where the ray misses the box within t_max or the slot is empty
// (`used`). Each box is the slab test of slab() in the node's grid: t = q * a + b per axis,
// with each axis's near and far planes chosen once per node by the ray's direction (nx..fz:
// the quantized coordinates of those planes).
uvec4 slot_keys(uint nx, uint ny, uint nz, uint fx, uint fy, uint fz, vec3 a, vec3 b, float t_max, uint used, uvec4 slots, out uint hits) {
    vec4 enter = max(max(slot_bytes(nx) * a.x + b.x, slot_bytes(ny) * a.y + b.y), max(slot_bytes(nz) * a.z + b.z, vec4(0.0)));
    vec4 exit = min(min(slot_bytes(fx) * a.x + b.x, slot_bytes(fy) * a.y + b.y), min(slot_bytes(fz) * a.z + b.z, vec4(t_max))) * 1.0000004;
    uvec4 keys = (floatBitsToUint(enter) & 0x7ffffff8u) | slots;
    bvec4 hit = lessThanEqual(enter, exit);
    bvec4 filled = notEqual(uvec4(used) & uvec4(0xffu, 0xff00u, 0xff0000u, 0xff000000u), uvec4(0u));
    uvec4 taken = uvec4(hit) & uvec4(filled);
    hits = taken.x | (taken.y << 1u) | (taken.z << 2u) | (taken.w << 3u);
    return keys * taken;
}

// A stack entry's reference for slot s of a node (w1: the node's word 1, imask its inner
// slots): an inner child's node index, or a leaf: bit 31, its triangle count less one in
// bits 29-30, its first triangle in bits 0-28 (LEAF_ENTRY in src/bvh/wide/traverse.rs).
uint slot_reference(uint s, uvec4 w1, uint imask) {
    if ((imask & (1u << s)) != 0u) return w1.x + uint(bitCount(imask & ((1u << s) - 1u)));
    uint meta = ((s < 4u ? w1.z : w1.w) >> ((s & 3u) * 8u)) & 0xffu;
    return 0x80000000u | (uint(bitCount(meta >> 5u)) - 1u) << 29u | (w1.y + (meta & 31u));
}

// The closest hit below hit.t, or with `first` (an AO ray's occlusion query) whether there
// is any: then it returns true at the first triangle hit.
bool traverse_wide(vec3 o, vec3 d, uint word_base, uint tri_base, bool first, inout Hit hit, inout uvec2 cost) {
    vec3 inv_d = safe_inverse(d);
    // Pending children: (reference, entry distance bits), the farthest deepest.
    uvec2 stack[WIDE_STACK_SIZE];
    uint sp = 0u;
    uvec2 entry = uvec2(0u, 0u);  // the root, entered at 0
    while (true) {
        // Each round visits a node and then, if the nearest child it hit is a leaf, tests
        // that leaf at once, so that lanes at a node and lanes at a leaf share one round
        // (as traverse_bvh tests a node's leaves in the node's round).
        bool live = uintBitsToFloat(entry.y) <= hit.t;
        if (live && (entry.x & 0x80000000u) == 0u) {
            uint at = word_base + entry.x * 5u;
            uvec4 w0 = wide_nodes[at];
            uvec4 w1 = wide_nodes[at + 1u];
            uvec4 w2 = wide_nodes[at + 2u];
            uvec4 w3 = wide_nodes[at + 3u];
            uvec4 w4 = wide_nodes[at + 4u];
            cost.x += 1u;
            vec3 origin = uintBitsToFloat(w0.xyz);
            // 2^(e - 127) from the biased exponent byte, exactly as the host's f32::from_bits.
            vec3 scale = uintBitsToFloat(uvec3(w0.w & 0xffu, (w0.w >> 8u) & 0xffu, (w0.w >> 16u) & 0xffu) << 23u);
            uint imask = w0.w >> 24u;
            // The node's frame folded into the ray: a box plane at grid coordinate q is
            // met at t = q * a + b. A ray going down an axis meets the hi plane first.
            vec3 a = scale * inv_d;
            vec3 b = (origin - o) * inv_d;
            uvec2 lo_x = w2.xy, lo_y = w2.zw, lo_z = w3.xy, hi_x = w3.zw, hi_y = w4.xy, hi_z = w4.zw;
            uvec2 near_x = inv_d.x >= 0.0 ? lo_x : hi_x, far_x = inv_d.x >= 0.0 ? hi_x : lo_x;
            uvec2 near_y = inv_d.y >= 0.0 ? lo_y : hi_y, far_y = inv_d.y >= 0.0 ? hi_y : lo_y;
            uvec2 near_z = inv_d.z >= 0.0 ? lo_z : hi_z, far_z = inv_d.z >= 0.0 ? hi_z : lo_z;
            uint hits_lo, hits_hi;
            uvec4 k_lo = slot_keys(near_x.x, near_y.x, near_z.x, far_x.x, far_y.x, far_z.x, a, b, hit.t, w1.z, uvec4(0u, 1u, 2u, 3u), hits_lo);
            uvec4 k_hi = slot_keys(near_x.y, near_y.y, near_z.y, far_x.y, far_y.y, far_z.y, a, b, hit.t, w1.w, uvec4(4u, 5u, 6u, 7u), hits_hi);
            uint hits = hits_lo | (hits_hi << 4u);
            uint n = uint(bitCount(hits));
            // An occlusion query takes any order: the slots in slot order, the last visited
            // next, no sort (and no distances: its t_max never shrinks).
            for (uint i = 0u; first && i < n; i++) {
                uint s = uint(findLSB(hits));
                hits &= hits - 1u;
                entry = uvec2(slot_reference(s, w1, imask), 0u);
                if (i + 1u < n) {
                    stack[sp] = entry;
                    sp += 1u;
                }
            }
            // Farthest first onto the stack; the last pick, the nearest, is visited next
            // (or, a leaf, tested below). A pick's slot is read off its key (keys are
            // unique), and its key cleared.
            for (uint i = 0u; !first && i < n; i++) {
                uvec4 m4 = max(k_lo, k_hi);
                uint m = max(max(m4.x, m4.y), max(m4.z, m4.w));
                uint s = m & 7u;
                k_lo = mix(k_lo, uvec4(0u), equal(k_lo, uvec4(m)));
                k_hi = mix(k_hi, uvec4(0u), equal(k_hi, uvec4(m)));
                entry = uvec2(slot_reference(s, w1, imask), m & ~7u);
                if (i + 1u < n) {
                    stack[sp] = entry;
                    sp += 1u;
                }
            }
            live = n > 0u;
        }
        // A leaf is tested in the round that reaches it. With LEAF_RUNS (the kernel of
        // --bvh wide-runs) so is every leaf popped after it: the lane drains the leaves
        // pending on top of its stack before its next node visit. The same entries in the
        // same order either way; only how a warp's lanes share rounds differs. (A separate
        // kernel: the loop cost the plain wide traversal 5% on the knots even when off.)
#ifdef LEAF_RUNS
        while (live && (entry.x & 0x80000000u) != 0u) {
#else
        if (live && (entry.x & 0x80000000u) != 0u) {
#endif
            // Its first two triangles loaded before either is tested, so that their
            // fetches overlap (as test_leaves does), as 16-byte words.
            uint k0 = tri_base + (entry.x & 0x1fffffffu);
            uint n = ((entry.x >> 29u) & 3u) + 1u;
            Triangle t0, t1;
            load_triangle_pair(k0, t0, t1);
            bool found = intersect_loaded(o, d, t0, k0, hit);
            if (n > 1u) found = intersect_loaded(o, d, t1, k0 + 1u, hit) || found;
            cost.y += min(n, 2u);
            if (first && found) return true;
            if (n > 2u) {
                found = intersect_triangle(o, d, k0 + 2u, hit);
                cost.y += 1u;
                if (first && found) return true;
            }
#ifdef LEAF_RUNS
            if (sp == 0u) {
                live = false;
                break;
            }
            sp -= 1u;
            entry = stack[sp];
            live = uintBitsToFloat(entry.y) <= hit.t;
#else
            live = false;
#endif
        }
        if (!live) {
            if (sp == 0u) break;
            sp -= 1u;
            entry = stack[sp];
        }
    }
    return false;
}

// Closest-hit queries: Möller–Trumbore (paper 3.3 step 2), the slab test, brute force
// over every triangle (the paper's mode) and BVH traversal. Mirrors src/geometry.rs and
// src/bvh/traverse.rs.

// Möller–Trumbore on a loaded triangle `tri` (index k): returns true and shrinks t_max
// when the triangle is hit closer.
bool intersect_loaded(vec3 o, vec3 d, Triangle tri, uint k, inout Hit hit) {
    vec3 e1 = tri.e1.xyz;
    vec3 e2 = tri.e2.xyz;
    vec3 p = cross(d, e2);
    float det = dot(e1, p);
    if (abs(det) < 1e-12) return false;
    float inv = 1.0 / det;
    vec3 tv = o - tri.v0.xyz;
    float u = dot(tv, p) * inv;
    if (u < 0.0 || u > 1.0) return false;
    vec3 q = cross(tv, e1);
    float v = dot(d, q) * inv;
    if (v < 0.0 || u + v > 1.0) return false;
    float t = dot(e2, q) * inv;
    if (t > 0.0 && t < hit.t) {
        hit.t = t;
        hit.u = u;
        hit.v = v;
        hit.tri = k;
        return true;
    }
    return false;
}

bool intersect_triangle(vec3 o, vec3 d, uint k, inout Hit hit) {
    return intersect_loaded(o, d, load_triangle(k), k, hit);
}

// Entry distance of the ray into the box, or INF when it misses within (0, t_max).
float slab(vec3 bmin, vec3 bmax, vec3 o, vec3 inv_d, float t_max) {
    vec3 t0 = (bmin - o) * inv_d;
    vec3 t1 = (bmax - o) * inv_d;
    vec3 lo = min(t0, t1);
    vec3 hi = max(t0, t1);
    float enter = max(max(lo.x, lo.y), max(lo.z, 0.0));
    // Widened by 2 ulp-ish (pbrt's 1 + 2*gamma3) so rays through a box corner are not lost to rounding.
    float exit = min(min(hi.x, hi.y), min(hi.z, t_max)) * 1.0000004;
    return enter <= exit ? enter : INF;
}

// 1/d without infinities (0 * inf would give NaN in the slab test).
vec3 safe_inverse(vec3 d) {
    vec3 s = vec3(d.x < 0.0 ? -1.0 : 1.0, d.y < 0.0 ? -1.0 : 1.0, d.z < 0.0 ? -1.0 : 1.0);
    return 1.0 / (s * max(abs(d), vec3(1e-20)));
}

// Leaves a and b (global first triangle, count; a count of 0 = nothing to test): the
// first two triangles of each are loaded before any is tested, so that the fetches
// overlap instead of queueing behind each other's latency. Tests run in the same order
// as leaf by leaf (a, then b).
void test_leaves(vec3 o, vec3 d, uint a, uint na, uint b, uint nb, inout Hit hit, inout uvec2 cost) {
    Triangle ta0, ta1, tb0, tb1;
    if (na > 0u) ta0 = load_triangle_halves(a);
    if (na > 1u) ta1 = load_triangle_halves(a + 1u);
    if (nb > 0u) tb0 = load_triangle_halves(b);
    if (nb > 1u) tb1 = load_triangle_halves(b + 1u);
    if (na > 0u) intersect_loaded(o, d, ta0, a, hit);
    if (na > 1u) intersect_loaded(o, d, ta1, a + 1u, hit);
    for (uint i = 2u; i < na; i++) intersect_triangle(o, d, a + i, hit);
    if (nb > 0u) intersect_loaded(o, d, tb0, b, hit);
    if (nb > 1u) intersect_loaded(o, d, tb1, b + 1u, hit);
    for (uint i = 2u; i < nb; i++) intersect_triangle(o, d, b + i, hit);
    cost.y += na + nb;
}

// Whether one of leaf triangles first..first+n is hit closer than t_max (an occlusion
// query's leaf: it stops at the first).
bool leaf_blocks(vec3 o, vec3 d, uint first, uint n, float t_max, inout uvec2 cost) {
    Hit hit;
    hit.t = t_max;
    for (uint i = 0u; i < n; i++) {
        cost.y += 1u;
        if (intersect_triangle(o, d, first + i, hit)) return true;
    }
    return false;
}

// Stack-based BVH2 traversal: leaves are tested as soon as their box is hit, inner
// children are visited near first with the far one pushed. Closest (`any` false): shrinks
// `hit` to the closest hit and returns false. Any (the AO view's occlusion query, hit.t its
// reach): returns true at the first triangle hit, leaf by leaf. One walk for both, as
// traverse_wide is (two functions drifted apart; on the H200 the one walk took the binary
// AO row 3% longer and Table 2's three and four geospheres 5-7% shorter, fortieth
// session). Mirrors src/bvh/traverse.rs (walk).
bool traverse_bvh(vec3 o, vec3 d, uint node_base, uint tri_base, bool any, inout Hit hit, inout uvec2 cost) {
    vec3 inv_d = safe_inverse(d);
    uint stack[STACK_SIZE];
    uint sp = 0u;
    uint node = 0u;
    while (true) {
        BvhNode n = nodes[node_base + node];
        cost.x += 1u;
        uint li = floatBitsToUint(n.left_min.w);
        uint lc = floatBitsToUint(n.left_max.w);
        uint ri = floatBitsToUint(n.right_min.w);
        uint rc = floatBitsToUint(n.right_max.w);
        float tl = (li == EMPTY) ? INF : slab(n.left_min.xyz, n.left_max.xyz, o, inv_d, hit.t);
        float tr = (ri == EMPTY) ? INF : slab(n.right_min.xyz, n.right_max.xyz, o, inv_d, hit.t);
        if (any) {
            // Leaf by leaf, each left as soon as a triangle blocks the ray.
            if (tl < INF && lc > 0u) {
                if (leaf_blocks(o, d, tri_base + li, lc, hit.t, cost)) return true;
                tl = INF;
            }
            if (tr < INF && rc > 0u) {
                if (leaf_blocks(o, d, tri_base + ri, rc, hit.t, cost)) return true;
                tr = INF;
            }
        } else {
            uint nl = (tl < INF) ? lc : 0u;
            uint nr = (tr < INF) ? rc : 0u;
            if (nl + nr > 0u) {
                test_leaves(o, d, tri_base + li, nl, tri_base + ri, nr, hit, cost);
                if (nl > 0u) tl = INF;
                if (nr > 0u) tr = INF;
            }
        }
        if (tl < INF && tr < INF) {
            // Both inner children: near first, far on the stack.
            if (tl <= tr) { stack[sp] = ri; node = li; } else { stack[sp] = li; node = ri; }
            sp += 1u;
        } else if (tl < INF) {
            node = li;
        } else if (tr < INF) {
            node = ri;
        } else {
            if (sp == 0u) break;
            sp -= 1u;
            node = stack[sp];
        }
    }
    return false;
}

#include "traverse_wide.glsl"

// No hit yet: nothing found closer than t_max.
Hit no_hit(float t_max) {
    Hit hit;
    hit.t = t_max;
    hit.tri = EMPTY;
    hit.instance = EMPTY;
    hit.u = 0.0;
    hit.v = 0.0;
    return hit;
}



// The paper's brute force over one mesh's triangles first..first+n, eight per iteration.
// Why eight: Mesa 22's lavapipe ends a loop after 65,535 iterations in one invocation
// (gallivm's loop limiter, counted over every time the loop runs), which cut a
// 22k-triangle mesh short at 2 bounces; eight per iteration lift that to 524k tests per loop
// and invocation. `any`: return true after the block of eight holding the first hit.
bool brute_force(vec3 o, vec3 d, uint first, uint n, bool any, inout Hit hit, inout uvec2 cost) {
    uint k = 0u;
    for (; k + 8u <= n; k += 8u) {
        bool found = intersect_triangle(o, d, first + k, hit);
        found = intersect_triangle(o, d, first + k + 1u, hit) || found;
        found = intersect_triangle(o, d, first + k + 2u, hit) || found;
        found = intersect_triangle(o, d, first + k + 3u, hit) || found;
        found = intersect_triangle(o, d, first + k + 4u, hit) || found;
        found = intersect_triangle(o, d, first + k + 5u, hit) || found;
        found = intersect_triangle(o, d, first + k + 6u, hit) || found;
        found = intersect_triangle(o, d, first + k + 7u, hit) || found;
        cost.y += 8u;
        if (any && found) return true;
    }
    for (; k < n; k++) {
        cost.y += 1u;
        if (intersect_triangle(o, d, first + k, hit) && any) return true;
    }
    return false;
}

// One instance's mesh along the ray: its wide or binary tree, or brute force. Closest
// (`any` false): shrinks `hit` to a closer hit of this instance and returns whether it did.
// Any: returns whether the mesh blocks the ray before hit.t.
bool visit_instance(uint i, vec3 o, vec3 d, bool any, bool use_bvh, inout Hit hit, inout uvec2 cost) {
    Instance inst = instances[i];
    uint first = inst.offsets.y;
    if (inst.offsets.x == EMPTY) return false;  // no triangles, and so no nodes of its own
    vec3 lo = point_to_object(inst, o);
    vec3 ld = vector_to_object(inst, d);
    uint before = hit.tri;
    bool blocked = false;
#ifdef WIDE_ONLY
    // The wide kernel runs only wide BVH frames of scenes whose every mesh has a wide tree
    // (TracePass picks it): the binary traversal and brute force are left out.
    blocked = traverse_wide(lo, ld, inst.offsets.z, first, any, hit, cost);
#else
#ifndef CORE_ONLY
    // The wide layout (`--bvh wide`); a mesh without a wide tree (EMPTY) takes the binary
    // path below.
    if (use_bvh && (frame.dims.w & FLAG_WIDE) != 0u && inst.offsets.z != EMPTY) {
        blocked = traverse_wide(lo, ld, inst.offsets.z, first, any, hit, cost);
    } else
#endif
    if (use_bvh) {
        blocked = traverse_bvh(lo, ld, inst.offsets.x, first, any, hit, cost);
    } else {
        blocked = brute_force(lo, ld, first, meshes[inst.offsets.w].x, any, hit, cost);
    }
#endif
    if (hit.tri != before) hit.instance = i;
    return any ? blocked : hit.tri != before;
}

// A top-level stack entry that is an instance to visit rather than a node.
const uint TOP_LEAF = 0x80000000u;

// The barycentrics (u, v) of `q`, a face point in its face's unit square, in the face
// triangle whose corners `code` names (three 2-bit codes, v0's lowest: bit 0 set where the
// corner sits at the box's max along the face's first in-plane axis, bit 1 along its
// second). Half the unit square, so the edges' determinant is 1 or -1, its own inverse.
// Mirrors face_barycentrics in src/tracer/enclosure.rs.
vec2 face_barycentrics(vec2 q, uint code) {
    vec2 c0 = vec2(float(code & 1u), float((code >> 1u) & 1u));
    vec2 e1 = vec2(float((code >> 2u) & 1u), float((code >> 3u) & 1u)) - c0;
    vec2 e2 = vec2(float((code >> 4u) & 1u), float((code >> 5u) & 1u)) - c0;
    vec2 w = q - c0;
    float det = e1.x * e2.y - e1.y * e2.x;
    return vec2(w.x * e2.y - w.y * e2.x, e1.x * w.y - e1.y * w.x) * det;
}

// The scene's enclosure tested as a closed box, `e` its record (src/tracer/enclosure.rs:
// EnclosureRecord): from inside, the slab test names the face the ray leaves by and its
// distance, and the point's place on the face names the face's triangle and gives its
// barycentrics, so no triangle is tested and a ray cannot slip between the two
// (ClosedBox::exit on the CPU; testing the face's two triangles made the model series
// 2-8% slower on the H200). A ray from the plane it leaves by (t = 0) meets no wall.
// From outside, all twelve are tested. Returns false where the record is no closed box:
// the walk then visits the enclosure as any instance. `blocked`: an occlusion query is
// blocked.
bool closed_box_hit(BvhNode e, vec3 o, vec3 d, bool occlusion, inout Hit hit, inout uvec2 cost, out bool blocked) {
    blocked = false;
    uint faces_low = floatBitsToUint(e.left_max.w);
    if (faces_low == EMPTY) return false;
    uint i = floatBitsToUint(e.left_min.w);
    Instance inst = instances[i];
    vec3 lo = point_to_object(inst, o);
    vec3 ld = vector_to_object(inst, d);
    uint first = inst.offsets.y;
    uint before = hit.tri;
    if (any(lessThan(lo, e.left_min.xyz)) || any(greaterThan(lo, e.left_max.xyz))) {
        // From outside: all twelve, in order (a plain loop: lavapipe's compiler takes
        // minutes over a kernel with more inlined copies of brute_force's unrolled one).
        for (uint k = 0u; k < 12u; k++) intersect_triangle(lo, ld, first + k, hit);
        cost.y += 12u;
    } else {
        bvec3 up = greaterThanEqual(ld, vec3(0.0));
        vec3 t3 = (mix(e.left_min.xyz, e.left_max.xyz, up) - lo) * safe_inverse(ld);
        // Selects, not indexing by axis: a vector indexed by a variable goes to local
        // memory (64 more bytes a lane here, 3% slower on the H200).
        bool x = t3.x <= t3.y && t3.x <= t3.z;
        bool y = !x && t3.y <= t3.z;
        float t = x ? t3.x : (y ? t3.y : t3.z);
        // The wall beyond what was found (or an occlusion query's reach): nothing to test.
        if (t > hit.t * 1.0001) return true;
        cost.y += 1u;
        if (t > 0.0 && t < hit.t) {
            uint axis = x ? 0u : (y ? 1u : 2u);
            uint face = 2u * axis + ((x ? up.x : (y ? up.y : up.z)) ? 1u : 0u);
            uint pair = face < 4u ? faces_low >> (8u * face) : floatBitsToUint(e.right_min.x) >> (8u * (face - 4u));
            uint codes = floatBitsToUint(x ? e.right_min.y : (y ? e.right_min.z : e.right_min.w)) >> (16u * (face & 1u));
            // right_max: 1 / the box's extent. The face's in-plane axes: the next two.
            vec3 rel = (lo + ld * t - e.left_min.xyz) * e.right_max.xyz;
            vec2 q = clamp(x ? rel.yz : (y ? rel.zx : rel.xy), vec2(0.0), vec2(1.0));
            vec2 uv = face_barycentrics(q, codes & 63u);
            uint slot = pair & 15u;
            if (uv.x < 0.0 || uv.y < 0.0 || uv.x + uv.y > 1.0) {
                uv = face_barycentrics(q, (codes >> 6u) & 63u);
                slot = (pair >> 4u) & 15u;
            }
            hit.t = t;
            hit.u = uv.x;
            hit.v = uv.y;
            hit.tri = first + slot;
        }
    }
    if (hit.tri != before) {
        hit.instance = i;
        blocked = occlusion;
    }
    return true;
}

// Where the ray o + t d enters the sphere (centre c, radius `radius`; 0 from inside), if it
// meets it for some t in [0, t_max], else INF; loosely: a ray that passes by within rounding
// may be let in, one that meets it is never turned away, and the entry is never later than
// the true one. From the ray's closest approach to the centre, which keeps its precision far
// from the sphere (Haines et al., Ray Tracing Gems, chapter 7). Mirrors sphere_entry in
// src/tracer/top_level/walk.rs.
float sphere_entry(vec3 c, float radius, vec3 o, vec3 d, float t_max) {
    vec3 oc = o - c;
    float inv_a = 1.0 / dot(d, d);
    float tm = -dot(oc, d) * inv_a;
    vec3 l = oc + tm * d;
    float r = radius + 1e-5 * (radius + length(oc));
    float h2 = r * r - dot(l, l);
    float dt = sqrt(max(h2, 0.0) * inv_a);
    return (h2 >= 0.0 && tm + dt >= 0.0 && tm - dt <= t_max * 1.0001) ? max(tm - dt, 0.0) : INF;
}

// Where the ray enters a top-level child (lo, hi: its words; INF for a miss or no child):
// its box, or with `spheres` (FLAG_SPHERES, the same for every lane) a sphere leaf's sphere
// (TOP_SPHERE: the instance's world bounding sphere where its mesh is round,
// src/tracer/top_level.rs). A ray that passes by a round mesh inside its box is then turned
// away before the instance's record, transform and tree are read: on the paper's geospheres
// 65-72% of the instances entered through their boxes gave no closer hit.
float child_entry(vec4 lo, vec4 hi, vec3 o, vec3 d, vec3 inv_d, float t_max, bool spheres) {
    if (floatBitsToUint(lo.w) == EMPTY) return INF;
    if (spheres && floatBitsToUint(hi.w) == TOP_SPHERE) return sphere_entry(lo.xyz, hi.x, o, d, t_max);
    return slab(lo.xyz, hi.xyz, o, inv_d, t_max);
}

// The top level: every instance whose box the ray meets, through the two-child tree over
// the instances' world boxes (top_nodes, leaves of one instance each; src/tracer/top_level.rs
// builds it and walks it the same way on the CPU). Of a node's two children the nearer is
// taken next and the farther pushed with its entry distance, and dropped when popped if
// the hits found meanwhile end before it. Brute force stays the paper's: every triangle of
// every instance, no culling. The one walk for closest hits and, with `any`, occlusion
// (true at the first blocking instance); visit_instance is called in one place only, so
// the traversals it holds are compiled once per query. Instance `skip` (EMPTY for none) is
// never visited: a convex mesh the ray leaves from outside (tracer/convex.rs).
#ifdef ONE_INSTANCE
// The kernel for scenes of one instance (a model alone, or inside a closed-box enclosure
// such as the mirror box; TracePass picks it for their BVH frames): the top level's root
// opened as the walk below opens it, with the same counts, and the instance visited outside
// any loop. The walk around the traversal (its stacks, and the state it keeps across a
// visit) cost a model alone 3-5% and a model in the box 8-9% on the H200 (twenty-seventh
// and twenty-eighth sessions); a loop of two visits (the box visited through its tree)
// cost more than the walk.
bool trace_instances(vec3 o, vec3 d, bool any, bool use_bvh, uint skip, uint hint, inout Hit hit, inout uvec2 cost) {
    if (frame.misc.x == 0u) return false;
    uint leaf = 0u;
    if (use_bvh) {
        BvhNode n = top_nodes[0];
        cost.x += 1u;
        // One child is the instance's leaf, the other empty or the enclosure, a closed box
        // (TracePass picks this kernel for such a scene's BVH frames), tested after the
        // instance: a ray that meets the model then skips the wall behind it (the box first
        // cost the framed rows 7-8% and a model in the box 7% on the H200). As
        // top_level::walk takes them.
        bool enclosed = floatBitsToUint(n.left_max.w) == TOP_ENCLOSURE;
        bool left = floatBitsToUint(n.left_min.w) != EMPTY && !enclosed;
        leaf = floatBitsToUint(left ? n.left_min.w : n.right_min.w);
        vec3 lo = left ? n.left_min.xyz : n.right_min.xyz;
        vec3 hi = left ? n.left_max.xyz : n.right_max.xyz;
        // Nested ifs, not &&: naga's GLSL front end evaluates both sides of && and ||, so
        // a visit on the right would run even where the left is false.
        if (leaf != skip) {
            if (slab(lo, hi, o, safe_inverse(d), hit.t) < INF) {
                if (visit_instance(leaf, o, d, any, use_bvh, hit, cost) && any) return true;
            }
        }
        bool blocked = false;
        if (enclosed) closed_box_hit(top_nodes[floatBitsToUint(n.left_min.w)], o, d, any, hit, cost, blocked);
        return blocked;
    }
    bool found = visit_instance(leaf, o, d, any, use_bvh, hit, cost);
    return any && found;
}
#else
bool trace_instances(vec3 o, vec3 d, bool any, bool use_bvh, uint skip, uint hint, inout Hit hit, inout uvec2 cost) {
    uint count = frame.misc.x;
    if (count == 0u) return false;
    vec3 inv_d = safe_inverse(d);
    // Pending entries: a node, or TOP_LEAF | an instance, and the bits of the distance at
    // which the ray enters it (one array of pairs, not two: 0.5-1.2% off the model series
    // on the H200).
    uvec2 stack[STACK_SIZE];
    uint sp = 0u;
    uint node = 0u;  // the next node to open, or EMPTY to pop
    uint next_brute = 0u;
    uint first = EMPTY;  // an instance to visit before anything else
#if defined(WIDE_ONLY) && !defined(SPHERE_LEAVES)
    // Its twin with SPHERE_LEAVES runs the frames of top levels with sphere leaves
    // (TracePass picks it): the spheres' code cost the fields of 10,000 knots, which have
    // none, 2-3% on the H200 even where the flag left it unused.
    const bool spheres = false;
#else
    bool spheres = (frame.dims.w & FLAG_SPHERES) != 0u;
#endif
    if (use_bvh) {
        BvhNode n = top_nodes[0];
        if (floatBitsToUint(n.left_max.w) == TOP_ENCLOSURE) {
            // The scene's enclosure (src/tracer/enclosure.rs: the paper's mirror box, whose
            // box holds every other instance) comes first, as a closed box or visited; the
            // tree over the others, the root's right child, waits on the stack. Left in the
            // tree, the enclosure sat by the root, where every ray visited it, and its box
            // spoilt the splits.
            cost.x += 1u;
            BvhNode e = top_nodes[floatBitsToUint(n.left_min.w)];
            uint enclosure = floatBitsToUint(e.left_min.w);
            if (hint == enclosure) hint = EMPTY;  // tested here, as always
            bool blocked;
            if (!closed_box_hit(e, o, d, any, hit, cost, blocked)) {
                if (enclosure != skip) first = enclosure;
            }
            if (blocked) return true;
            node = EMPTY;
            uint ri = floatBitsToUint(n.right_min.w);
            float tr = child_entry(n.right_min, n.right_max, o, d, inv_d, hit.t, spheres);
            if (tr < INF) {
                stack[0] = uvec2(floatBitsToUint(n.right_max.w) > 0u ? ri | TOP_LEAF : ri, floatBitsToUint(tr));
                sp = 1u;
            }
        }
    }
    // The copy this pixel's camera ray hit in the last frame (`hint`, EMPTY for none) is
    // visited before the walk: its hit, where it is still there, bounds the walk at once, and
    // the lanes of a warp enter their copies together instead of one lane after another as
    // the walk reaches them. The walk then leaves it out, as it leaves out `skip` (which a
    // camera ray has none of). Any copy may be the hint: the walk still visits every copy
    // it enters before the closest hit, so the hit is the same.
    if (use_bvh && first == EMPTY && hint < count && skip == EMPTY) {
        first = hint;
        skip = hint;
    }
    while (true) {
        uint leaf = first;
        bool forced = leaf != EMPTY;  // the enclosure or the hint, visited whatever `skip` is
        first = EMPTY;
        if (!use_bvh) {
            if (next_brute == count) break;
            leaf = next_brute;
            next_brute += 1u;
        }
        while (use_bvh && leaf == EMPTY) {
            if (node == EMPTY) {
                if (sp == 0u) break;
                sp -= 1u;
                if (uintBitsToFloat(stack[sp].y) > hit.t) continue;  // begins beyond the closest hit found since
                uint e = stack[sp].x;
                if ((e & TOP_LEAF) != 0u) {
                    leaf = e & ~TOP_LEAF;
                    break;
                }
                node = e;
            }
            BvhNode n = top_nodes[node];
            cost.x += 1u;
            uint li = floatBitsToUint(n.left_min.w);
            uint ri = floatBitsToUint(n.right_min.w);
            float tl = child_entry(n.left_min, n.left_max, o, d, inv_d, hit.t, spheres);
            float tr = child_entry(n.right_min, n.right_max, o, d, inv_d, hit.t, spheres);
            // Leaves (count > 0) are entered as instances to visit.
            if (floatBitsToUint(n.left_max.w) > 0u) li |= TOP_LEAF;
            if (floatBitsToUint(n.right_max.w) > 0u) ri |= TOP_LEAF;
            bool swap = tr < tl;
            float tn = swap ? tr : tl, tf = swap ? tl : tr;
            uint near = swap ? ri : li, far = swap ? li : ri;
            node = EMPTY;
            if (tf < INF) {
                stack[sp] = uvec2(far, floatBitsToUint(tf));
                sp += 1u;
            }
            if (tn < INF) {
                if ((near & TOP_LEAF) != 0u) leaf = near & ~TOP_LEAF; else node = near;
            }
        }
        if (leaf == EMPTY) break;
        // Not `leaf != skip && visit_instance(...)`: naga evaluates both sides of &&.
        if (leaf != skip || forced) {
            if (visit_instance(leaf, o, d, any, use_bvh, hit, cost) && any) return true;
        }
    }
    return false;
}
#endif

#if !defined(ONE_INSTANCE) && !defined(SPHERE_LEAVES)
// The pixel being traced (trace_pixel sets it): a camera ray's walk starts from the copy
// the last frame's ray hit there (walk_hints, scene.glsl), and records the copy this one
// hits. On the H200 that took 10-12% off the fields of 10,000 1M knots, whose lanes then
// enter their copies together (docs/BENCHMARKS.md, forty-first session), and cost 27 and
// 100 1M knots in the box 2.5-3.6% (the kernel at 128 registers). Not for top levels with
// sphere leaves or convex copies (the wide kernel's twin, SPHERE_LEAVES; FLAG_SPHERES,
// FLAG_CONVEX in the others): the walk turns those rays away from the copies they pass by
// already, and the hints' reads and writes cost the paper's geospheres up to 3%.
#define HAS_WALK_HINTS
uint hint_pixel = 0u;
#endif

// The closest hit over all instances in (0, inf), but instance `skip` (EMPTY for none),
// which the ray cannot meet.
Hit closest_hit(vec3 o, vec3 d, bool use_bvh, uint skip, inout uvec2 cost) {
    Hit hit = no_hit(INF);
#ifdef HAS_WALK_HINTS
    // A camera ray leaves from the camera (a bounce ray that started there would only take
    // a hint, never another hit, and leave one).
    bool camera = all(equal(o, frame.cam_origin_eps.xyz)) && (frame.dims.w & (FLAG_SPHERES | FLAG_CONVEX)) == 0u;
    uint hint = EMPTY;
    if (camera) hint = walk_hints[hint_pixel];  // not `?:`, whose both sides naga evaluates
    trace_instances(o, d, false, use_bvh, skip, hint, hit, cost);
    if (camera) walk_hints[hint_pixel] = hit.instance;
#else
    trace_instances(o, d, false, use_bvh, skip, EMPTY, hit, cost);
#endif
    return hit;
}

// Whether any instance but `skip` has a triangle along the ray in (0, t_max): the AO
// view's occlusion query.
bool any_hit(vec3 o, vec3 d, float t_max, bool use_bvh, uint skip, inout uvec2 cost) {
    Hit hit = no_hit(t_max);
    return trace_instances(o, d, true, use_bvh, skip, EMPTY, hit, cost);
}

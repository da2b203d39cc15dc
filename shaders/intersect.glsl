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

// Stack-based BVH2 traversal: leaves are tested as soon as their box is hit, inner
// children are visited near first with the far one pushed.
void traverse_bvh(vec3 o, vec3 d, uint node_base, uint tri_base, inout Hit hit, inout uvec2 cost) {
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
        uint nl = (tl < INF) ? lc : 0u;
        uint nr = (tr < INF) ? rc : 0u;
        if (nl + nr > 0u) {
            test_leaves(o, d, tri_base + li, nl, tri_base + ri, nr, hit, cost);
            if (nl > 0u) tl = INF;
            if (nr > 0u) tr = INF;
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

// The closest hit over all instances in (0, t_max). Instances carry a uniform scale, so
// the object-space ray keeps world-space distances.
Hit closest_hit(vec3 o, vec3 d, bool use_bvh, inout uvec2 cost) {
    Hit hit = no_hit(INF);
    uint count = frame.misc.x;
    vec3 inv_d = safe_inverse(d);
    for (uint i = 0u; i < count; i++) {
        Instance inst = instances[i];
        // Top level: skip instances whose box the ray misses or meets beyond the closest
        // hit so far. Brute force stays the paper's: every triangle, no culling.
        if (use_bvh && slab(inst.bounds_min.xyz, inst.bounds_max.xyz, o, inv_d, hit.t) == INF) continue;
        float s = inst.translation_scale.w;
        vec3 lo = (o - inst.translation_scale.xyz) / s;
        vec3 ld = d / s;
        uint before = hit.tri;
#ifdef WIDE_ONLY
        // The wide kernel runs only wide BVH frames of scenes whose every mesh has a wide
        // tree (TracePass picks it): the binary traversal and brute force are left out.
        if (inst.offsets.z > 0u) traverse_wide(lo, ld, floatBitsToUint(inst.bounds_min.w), inst.offsets.y, false, hit, cost);
#else
#ifndef CORE_ONLY
        // The wide layout (`--bvh wide`); an empty mesh has no wide nodes, and a mesh
        // without a wide tree (EMPTY) takes the binary path below.
        uint wide_words = floatBitsToUint(inst.bounds_min.w);
        if (use_bvh && (frame.dims.w & FLAG_WIDE) != 0u && wide_words != EMPTY) {
            if (inst.offsets.z > 0u) traverse_wide(lo, ld, wide_words, inst.offsets.y, false, hit, cost);
        } else
#endif
        if (use_bvh) {
            traverse_bvh(lo, ld, inst.offsets.x, inst.offsets.y, hit, cost);
        } else {
            // The paper's brute force: every triangle of every model, eight per iteration.
            // Why eight: Mesa 22's lavapipe ends a loop after 65,535 iterations in one
            // invocation (gallivm's loop limiter, counted over every time the loop runs),
            // which cut a 22k-triangle mesh short at 2 bounces; eight per iteration lift
            // that to 524k tests per loop and invocation.
            uint first = inst.offsets.y, n = inst.offsets.z, k = 0u;
            for (; k + 8u <= n; k += 8u) {
                intersect_triangle(lo, ld, first + k, hit);
                intersect_triangle(lo, ld, first + k + 1u, hit);
                intersect_triangle(lo, ld, first + k + 2u, hit);
                intersect_triangle(lo, ld, first + k + 3u, hit);
                intersect_triangle(lo, ld, first + k + 4u, hit);
                intersect_triangle(lo, ld, first + k + 5u, hit);
                intersect_triangle(lo, ld, first + k + 6u, hit);
                intersect_triangle(lo, ld, first + k + 7u, hit);
            }
            for (; k < n; k++) intersect_triangle(lo, ld, first + k, hit);
            cost.y += n;
        }
#endif
        if (hit.tri != before) hit.instance = i;
    }
    return hit;
}

// Any-hit (occlusion) queries for the AO view: whether anything lies along the ray in
// (0, t_max). The same traversal as traverse_bvh (or traverse_wide with `first`), but it
// returns at the first triangle hit instead of looking on for a closer one: an AO ray only
// asks whether it is blocked.
// Mirrors src/bvh/traverse.rs (any_hit) and src/tracer/cpu.rs (CpuScene::any_hit).

// Whether one of leaf triangles first..first+n is hit closer than t_max.
bool leaf_blocks(vec3 o, vec3 d, uint first, uint n, float t_max, inout uvec2 cost) {
    Hit hit;
    hit.t = t_max;
    for (uint i = 0u; i < n; i++) {
        cost.y += 1u;
        if (intersect_triangle(o, d, first + i, hit)) return true;
    }
    return false;
}

// traverse_bvh's stack walk with early exit: leaves tested as their box is hit, inner
// children near first, the first hit ends it.
bool traverse_bvh_any(vec3 o, vec3 d, uint node_base, uint tri_base, float t_max, inout uvec2 cost) {
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
        float tl = (li == EMPTY) ? INF : slab(n.left_min.xyz, n.left_max.xyz, o, inv_d, t_max);
        float tr = (ri == EMPTY) ? INF : slab(n.right_min.xyz, n.right_max.xyz, o, inv_d, t_max);
        if (tl < INF && lc > 0u) {
            if (leaf_blocks(o, d, tri_base + li, lc, t_max, cost)) return true;
            tl = INF;
        }
        if (tr < INF && rc > 0u) {
            if (leaf_blocks(o, d, tri_base + ri, rc, t_max, cost)) return true;
            tr = INF;
        }
        if (tl < INF && tr < INF) {
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

// Whether any instance has a triangle along the ray in (0, t_max): our BVH with early exit,
// or brute force that stops after the block of eight holding the first hit.
bool any_hit(vec3 o, vec3 d, float t_max, bool use_bvh, inout uvec2 cost) {
    uint count = frame.misc.x;
    vec3 inv_d = safe_inverse(d);
    for (uint i = 0u; i < count; i++) {
        Instance inst = instances[i];
        if (inst.offsets.z == 0u) continue;  // no triangles, and so no nodes of its own
        if (use_bvh && slab(inst.bounds_min.xyz, inst.bounds_max.xyz, o, inv_d, t_max) == INF) continue;
        float s = inst.translation_scale.w;
        vec3 lo = (o - inst.translation_scale.xyz) / s;
        vec3 ld = d / s;
#ifndef CORE_ONLY
        // The wide layout, as closest_hit takes it.
        uint wide_words = floatBitsToUint(inst.bounds_min.w);
        if (use_bvh && (frame.dims.w & FLAG_WIDE) != 0u && wide_words != EMPTY) {
            Hit hit = no_hit(t_max);
            if (traverse_wide(lo, ld, wide_words, inst.offsets.y, true, hit, cost)) return true;
        } else
#endif
        if (use_bvh) {
            if (traverse_bvh_any(lo, ld, inst.offsets.x, inst.offsets.y, t_max, cost)) return true;
        } else {
            // Eight per iteration, as closest_hit's brute force (lavapipe's loop limit).
            Hit hit;
            hit.t = t_max;
            uint first = inst.offsets.y, n = inst.offsets.z, k = 0u;
            for (; k + 8u <= n; k += 8u) {
                bool blocked = intersect_triangle(lo, ld, first + k, hit);
                blocked = intersect_triangle(lo, ld, first + k + 1u, hit) || blocked;
                blocked = intersect_triangle(lo, ld, first + k + 2u, hit) || blocked;
                blocked = intersect_triangle(lo, ld, first + k + 3u, hit) || blocked;
                blocked = intersect_triangle(lo, ld, first + k + 4u, hit) || blocked;
                blocked = intersect_triangle(lo, ld, first + k + 5u, hit) || blocked;
                blocked = intersect_triangle(lo, ld, first + k + 6u, hit) || blocked;
                blocked = intersect_triangle(lo, ld, first + k + 7u, hit) || blocked;
                cost.y += 8u;
                if (blocked) return true;
            }
            for (; k < n; k++) {
                cost.y += 1u;
                if (intersect_triangle(lo, ld, first + k, hit)) return true;
            }
        }
    }
    return false;
}

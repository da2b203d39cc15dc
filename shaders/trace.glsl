// The tracer (paper 3.3), shared by every way of finding hits: one pixel's camera rays,
// the closest hit, Blinn–Phong at the hit, then mirror bounces blended with the colour so
// far at the reflection ratio. On top, the paper's future work: smooth shading, textures
// (ray-cone mip selection), an environment map, jittered supersampling with progressive
// accumulation, and adaptive sampling on edges seen directly or in the mirrors.
// The CPU twin is src/tracer/cpu.rs.
//
// The includer declares the scene (scene.glsl), `Hit closest_hit(o, d, use_bvh, skip, cost)`
// and the AO view's occlusion query `bool any_hit(o, d, t_max, use_bvh, skip, cost)`
// (`skip`: an instance the ray cannot meet, or EMPTY; left_behind): our BVH or brute
// force (intersect.glsl, trace.comp) or the driver's traversal (vendor/query.comp,
// vendor/raygen.rgen), then calls trace_pixel from its entry point.

#include "texture.glsl"
#include "shade.glsl"

// PCG hash (Jarzynski & Olano 2020): the sample jitter, identical on the CPU.
uint pcg(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

float random01(inout uint seed) {
    seed = pcg(seed);
    return float(seed >> 8) * (1.0 / 16777216.0);
}

// The AO view: the fraction of `frame.light_color.w` (uint bits) cosine-weighted rays
// around the shading normal ns, leaving from p lifted off the surface along ng (facing the
// viewer), that meet nothing closer than the radius `frame.light_pos.w`; instance `skip`
// (left_behind) is not looked at. Each ray's
// direction depends only on the camera sample's seed and the ray's index, through the PCG
// hash, so the CPU's CpuScene::ambient_occlusion draws exactly these rays.
float ambient_occlusion(vec3 p, vec3 ng, vec3 ns, uint sample_seed, bool use_bvh, uint skip, inout uvec2 cost) {
    uint rays = floatBitsToUint(frame.light_color.w);
    float radius = frame.light_pos.w;
    vec3 o = p + ng * frame.cam_origin_eps.w;
    // A frame around ns without a branch on its direction (Duff et al. 2017).
    float sgn = ns.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sgn + ns.z);
    float b = ns.x * ns.y * a;
    vec3 tangent = vec3(1.0 + sgn * ns.x * ns.x * a, sgn * b, -sgn * ns.x);
    vec3 bitangent = vec3(b, sgn + ns.y * ns.y * a, -ns.y);
    uint open = 0u;
    for (uint j = 0u; j < rays; j++) {
        uint seed = pcg(sample_seed ^ pcg(j + AO_SEED_SALT));
        float u1 = random01(seed);
        float u2 = random01(seed);
        float r = sqrt(u1);
        float phi = 6.2831855 * u2;
        vec3 d = normalize(tangent * (r * cos(phi)) + bitangent * (r * sin(phi)) + ns * sqrt(max(1.0 - u1, 0.0)));
        // A smooth normal may tip a direction under the triangle: mirror it back above.
        float below = dot(d, ng);
        if (below < 0.0) d -= 2.0 * below * ng;
        if (!any_hit(o, d, radius, use_bvh, skip, cost)) open += 1u;
    }
    return float(open) / float(max(rays, 1u));
}

// The instance a ray leaving a hit on instance `instance` (record `inst`) skips: the hit's
// own where its mesh is convex and the ray met the mesh from outside (`back`: it met the
// triangle's back, as cross(e1, e2) faces), since it leaves lifted off that side and
// heading away from the triangle's plane, behind which the whole mesh lies
// (tracer/convex.rs); else EMPTY. Brute force, the paper's every triangle, skips nothing.
// The plain wide kernel skips nothing (src/gpu/shader_compile.rs: SPHERE_LEAVES): the skip
// took it from 96 registers to 128, and the knot fields 7% slower on the H200; frames of
// scenes with convex copies run its twin (FLAG_CONVEX).
uint left_behind(Instance inst, uint instance, bool back, bool use_bvh) {
#if defined(WIDE_ONLY) && !defined(SPHERE_LEAVES) && !defined(ONE_INSTANCE)
    return EMPTY;
#else
    uint convex = meshes[inst.offsets.w].z;
    return use_bvh && convex == (back ? CONVEX_INWARD : CONVEX_OUTWARD) ? instance : EMPTY;
#endif
}

// One surface of a path, for adaptive sampling's edge test: the instance, material and
// plane of the hit triangle, so a quad's diagonal (two coplanar triangles of one material)
// is no edge but a silhouette or a crease is.
uint surface_key(Hit hit) {
    if (hit.tri == EMPTY) return EMPTY;
    Triangle tri = load_triangle(hit.tri);
    vec3 n = normalize(cross(tri.e1.xyz, tri.e2.xyz));
    if (n.x < 0.0 || (n.x == 0.0 && (n.y < 0.0 || (n.y == 0.0 && n.z < 0.0)))) n = -n;
    ivec3 q = ivec3(round(n * 1024.0));
    uint key = pcg(uint(q.x) ^ pcg(uint(q.y) ^ pcg(uint(q.z))));
    key = pcg(key ^ shading[hit.tri].material) ^ pcg(hit.instance + 0x9e3779b9u);
    return key == EMPTY ? 0u : key;
}

// Folds the surface a path reaches into its key while it still shows in 8 bits: an edge
// seen in a mirror changes the key as much as one seen directly.
const float KEY_MIN_THROUGHPUT = 1.0 / 256.0;

void add_to_path_key(inout uint key, uint surface, float throughput) {
    if (throughput >= KEY_MIN_THROUGHPUT) key = pcg(key ^ surface);
}

// The colour (or AOV) of one camera sample at `pos` (pixel units, row 0 at the top), and
// with `keyed` (adaptive sampling's pre-pass) the key of the surfaces along its path (the
// edge test). `sample_seed` seeds the AO view's rays.
//
// What the loop carries from bounce to bounce is kept small: the kernels that walk a top
// level were at 128 registers, and a lane's state across the bounces' traversals is what
// put them there (an AOV's value set only as the loop ends, not carried; the throughput
// one float, since a mirror scales every channel alike; the key's code gone from the
// frame's calls). Returns inside the loop instead of breaks cost the AO view 3% on the H200.
vec4 trace_sample(vec2 pos, uint aov, uint sample_seed, bool use_bvh, bool keyed, inout uvec2 cost, inout uint key) {
    uint width = frame.dims.x;
    uint height = frame.dims.y;
    uint flags = frame.dims.w;
    vec2 ndc = vec2(pos.x / float(width) * 2.0 - 1.0, 1.0 - pos.y / float(height) * 2.0);
    vec3 o = frame.cam_origin_eps.xyz;
    vec3 d = normalize(frame.cam_forward_blend.xyz + ndc.x * frame.cam_right_ambient.xyz + ndc.y * frame.cam_up.xyz);

    uint bounces = (aov == AOV_COLOR || aov == AOV_COST || aov == AOV_SAMPLES) ? frame.dims.z & BOUNCES_MASK : 0u;
    float blend = frame.cam_forward_blend.w;
    float eps = frame.cam_origin_eps.w;
    // Ray cone: the angle one pixel subtends; flat mirrors keep it, so the footprint at a
    // hit is this angle times the path length so far.
    float spread = 2.0 * length(frame.cam_up.xyz) / float(height);
    float path_length = 0.0;

    vec3 color = vec3(0.0);
    float throughput = 1.0;
    // An AOV's value, set only just before the loop ends, so that it is no state the loop
    // carries (the cost view's colour, and a single-value AOV's miss, keep this one).
    vec4 aux = vec4(-1.0, -1.0, -1.0, 0.0);

    // The instance the next ray cannot meet (left_behind): none for the camera's.
    uint skip = EMPTY;
    for (uint bounce = 0u; bounce <= bounces; bounce++) {
        Hit hit = closest_hit(o, d, use_bvh, skip, cost);
        if (hit.tri == EMPTY) {
            if (keyed) add_to_path_key(key, EMPTY, throughput);
            vec3 miss = (flags & FLAG_ENVIRONMENT) != 0u ? sample_environment(d) : unpackUnorm4x8(frame.misc.z).rgb;
            color += throughput * miss;
            if (bounce == 0u && aov == AOV_NORMAL) aux = vec4(0.0);
#ifndef NO_AO_VIEW
            if (bounce == 0u && aov == AOV_AO) aux = vec4(1.0, 1.0, 1.0, 0.0);  // open sky, no coverage
#endif
            break;
        }
        if (keyed) add_to_path_key(key, surface_key(hit), throughput);
        path_length += hit.t;
        Triangle tri = load_triangle(hit.tri);
        Instance inst = instances[hit.instance];
        vec3 p = o + d * hit.t;
        // The triangle's normals in its mesh's space, turned to the viewer there (the same
        // side as in the world: dot(W^T n, d) = dot(n, W d)), then carried to the world
        // by the instance's inverse transpose, which keeps a mirrored mesh's outward side.
        vec3 d_object = vector_to_object(inst, d);
        vec3 ng_object = normalize(cross(tri.e1.xyz, tri.e2.xyz));
        bool back = dot(ng_object, d_object) > 0.0;
        if (back) ng_object = -ng_object;  // two-sided
        vec3 ns_object = ng_object;
        bool smooth_hit = false;
        float side = 1.0;  // the corner normals flipped to the viewer's side
        vec3 n0 = vec3(0.0), n1 = vec3(0.0), n2 = vec3(0.0);
        if ((flags & FLAG_SMOOTH) != 0u) {
            uvec3 c = shading[hit.tri].corners;
            n0 = vertex_normal(c.x);
            n1 = vertex_normal(c.y);
            n2 = vertex_normal(c.z);
            vec3 interp = n0 * (1.0 - hit.u - hit.v) + n1 * hit.u + n2 * hit.v;
            if (dot(interp, interp) > 1e-12) {
                ns_object = normalize(interp);
                smooth_hit = true;
                if (dot(ns_object, ng_object) < 0.0) {  // normals wound against the triangle
                    ns_object = -ns_object;
                    side = -1.0;
                }
            }
        }
        vec3 ng = normalize(normal_to_world(inst, ng_object));
        vec3 ns = normalize(normal_to_world(inst, ns_object));
#ifndef NO_AO_VIEW
        if (aov == AOV_AO) {
            uint behind = left_behind(inst, hit.instance, back, use_bvh);
            aux = vec4(vec3(ambient_occlusion(p, ng, ns, sample_seed, use_bvh, behind, cost)), 1.0);
            break;
        }
#endif
        // The single-value AOVs trace no bounce: their value is the first hit's.
        if (aov == AOV_DEPTH) {
            aux = vec4(hit.t, hit.t, hit.t, 1.0);
            break;
        }
        if (aov == AOV_NORMAL) {
            aux = vec4(ns, 1.0);
            break;
        }
        if (aov == AOV_PRIM_ID) {
            float prim = float(triangle_prim(hit.tri) + meshes[inst.offsets.w].y);
            aux = vec4(prim, prim, prim, 1.0);
            break;
        }
        TriangleShading sh = shading[hit.tri];
        Material mat = materials[sh.material];
        vec3 kd = mat.diffuse_mirror.rgb;
        if ((flags & FLAG_TEXTURES) != 0u && (mat.texture.y & MATERIAL_VERTEX_COLORS) != 0u) {
            uvec3 c = shading[hit.tri].corners;
            kd *= unpackUnorm4x8(vertex_colors[c.x]).rgb * (1.0 - hit.u - hit.v)
                + unpackUnorm4x8(vertex_colors[c.y]).rgb * hit.u + unpackUnorm4x8(vertex_colors[c.z]).rgb * hit.v;
        }
        if ((flags & FLAG_TEXTURES) != 0u && mat.texture.x != EMPTY) {
            uvec3 c = shading[hit.tri].corners;
            vec2 uv0 = material_uv(mat, vertex_texcoords[c.x]);
            vec2 uv1 = material_uv(mat, vertex_texcoords[c.y]);
            vec2 uv2 = material_uv(mat, vertex_texcoords[c.z]);
            vec2 uv = uv0 * (1.0 - hit.u - hit.v) + uv1 * hit.u + uv2 * hit.v;
            uvec4 info = texture_infos[mat.texture.x];
            float world_area = 0.5 * world_area_of(inst, cross(tri.e1.xyz, tri.e2.xyz));
            vec2 duv1 = uv1 - uv0;
            vec2 duv2 = uv2 - uv0;
            float texel_area = 0.5 * abs(duv1.x * duv2.y - duv1.y * duv2.x) * float(info.y) * float(info.z);
            float lod = 0.0;
            if (world_area > 0.0 && texel_area > 0.0) {
                float width_at_hit = spread * path_length;
                lod = log2(max(width_at_hit, 1e-20)) + 0.5 * log2(texel_area / world_area) - log2(max(abs(dot(ng, d)), 1e-4));
            }
            kd *= sample_material_texture(mat, uv, lod).rgb;
        }
        vec3 l = normalize(frame.light_pos.xyz - p);
        // Whether the light reaches the hit is decided in the mesh's space (the signs of
        // dot(n, l) are the same there), where the terminator's offset is made.
        bool lit = light_reaches(vector_to_object(inst, l), ng_object, ns_object, smooth_hit,
                                 hit.u, hit.v, tri.e1.xyz, tri.e2.xyz, n0 * side, n1 * side,
                                 n2 * side, point_to_object(inst, p),
                                 point_to_object(inst, frame.light_pos.xyz));
        vec3 local_color = blinn_phong(kd, mat, l, ns, lit, -d);
        float r = blend * mat.diffuse_mirror.a;
        if (bounce == bounces) {
            color += throughput * local_color;
            break;
        }
        // mix(local, reflected, r): the local part now, the reflected part next bounce.
        color += throughput * (1.0 - r) * local_color;
        throughput *= r;
        if (r <= 0.0) break;
        vec3 reflected = reflect(d, ns);
        // A shading normal must not send the ray through the surface.
        if (dot(reflected, ng) <= 0.0) reflected = reflect(d, ng);
        o = p + ng * eps;
        d = reflected;
        skip = left_behind(inst, hit.instance, back, use_bvh);
    }
    if (aov == AOV_COLOR || aov == AOV_SAMPLES) return vec4(color, 1.0);
    return aux;
}

// Whether `lane` of a work group's tile (y * width + x) is in the dispatch's band: a band
// finer than a group (brute force on a big scene, on a slow device) traces a run of its
// lanes and the others return at once, writing nothing. One compare (wrapping below
// `first`); every lane passes for a band of whole groups.
bool in_band(uint lane) {
    uint first = (frame.dims.z >> FIRST_LANE_SHIFT) & LANE_MASK;
    uint span = (frame.dims.z >> LANE_SPAN_SHIFT) & LANE_MASK;
    return lane - first <= span;
}

// Everything the frame asks of pixel `px` (row 0 at the top): the adaptive pre-pass key, or
// its samples, accumulated and written to the outputs. Returns what the pixel cost (BVH
// nodes visited plus triangles tested, at most 2^24; 0 outside the frame and in the
// pre-pass), which trace.comp's tile order feeds on.
uint trace_pixel(uvec2 px) {
    uint width = frame.dims.x;
    uint height = frame.dims.y;
    if (px.x >= width || px.y >= height) return 0u;
    uint pixel = px.y * width + px.x;
    uint flags = frame.dims.w;
#ifdef HAS_WALK_HINTS
    hint_pixel = pixel;
#endif
#if defined(WIDE_ONLY) && !defined(ONE_INSTANCE)
    // The wide kernel runs wide BVH frames only (TracePass picks it): known here, the top
    // level's walk loses its brute-force path and the state that path keeps (the model
    // series 1-3% faster on the H200). Not in the one-instance twin, where it cost 1%.
    const bool use_bvh = true;
#else
    bool use_bvh = (flags & FLAG_BVH) != 0u;
#endif
    uint aov = (flags >> AOV_SHIFT) & AOV_MASK;

    if ((flags & FLAG_ID_PASS) != 0u) {
        // The key of the path through the pixel centre: primary hit and mirror bounces.
        uvec2 unused_cost = uvec2(0u);
        uint key = 0u;
        trace_sample(vec2(px) + 0.5, AOV_COLOR, 0u, use_bvh, true, unused_cost, key);
        prim_ids[pixel] = key;
        return 0u;
    }

    uint frame_index = frame.misc.w;
    uint spp = max((flags >> SPP_SHIFT) & SPP_MASK, 1u);
    bool single_value = aov == AOV_DEPTH || aov == AOV_NORMAL || aov == AOV_PRIM_ID;
    if (single_value) spp = 1u;
    if ((flags & FLAG_ADAPTIVE) != 0u && !single_value) {
        // Extra samples only where a 4-neighbour's path met other surfaces.
        uint id = prim_ids[pixel];
        uint l = prim_ids[px.y * width + (px.x > 0u ? px.x - 1u : px.x)];
        uint r = prim_ids[px.y * width + min(px.x + 1u, width - 1u)];
        uint u = prim_ids[(px.y > 0u ? px.y - 1u : px.y) * width + px.x];
        uint dn = prim_ids[min(px.y + 1u, height - 1u) * width + px.x];
        bool edge = l != id || r != id || u != id || dn != id;
        if (!edge) spp = 1u;
    }
#ifdef WIDE_ONLY
    // The wide kernels trace one sample a pixel; frames of more run the full kernel
    // (trace_kernels::variant). Without the sample loop's state live across the trace, the
    // wide kernels that walk a top level take 96 registers instead of 128, and 5 work groups
    // fit an SM instead of 4: the model series 4-6% faster on the H200 (docs/BENCHMARKS.md,
    // "Thirty-fifth session").
    spp = 1u;
#endif
    // The paper's single ray through the centre unless several samples are asked for.
    bool jitter = !single_value && (spp > 1u || frame_index > 0u);

    uvec2 cost = uvec2(0u);
    uint key = 0u;
    vec4 sum = vec4(0.0);
    for (uint s = 0u; s < spp; s++) {
        vec2 offset = vec2(0.5);
        // The sample's seed: its jitter and its AO rays (a new set each accumulated frame).
        uint sample_seed = pcg(pixel ^ pcg(frame_index * 256u + s));
        if (jitter) {
            uint seed = sample_seed;
            offset = vec2(random01(seed), random01(seed));
        }
        sum += trace_sample(vec2(px) + offset, aov, sample_seed, use_bvh, false, cost, key);
    }
    vec4 value = sum / float(spp);

    if (aov == AOV_COLOR || aov == AOV_AO) {
        if (frame_index > 0u) {
            // Progressive accumulation: running mean over frames (AO: over new rays).
            vec4 previous = out_float[pixel];
            value = previous + (value - previous) / float(frame_index + 1u);
        }
        out_float[pixel] = value;
        out_rgba8[pixel] = packUnorm4x8(vec4(clamp(value.rgb, 0.0, 1.0), 1.0));
    } else if (aov == AOV_COST) {
        out_float[pixel] = vec4(float(cost.x), float(cost.y), 0.0, 1.0);
        out_rgba8[pixel] = packUnorm4x8(vec4(clamp(value.rgb, 0.0, 1.0), 1.0));
    } else if (aov == AOV_SAMPLES) {
        out_float[pixel] = vec4(float(spp), float(spp), float(spp), 1.0);
        out_rgba8[pixel] = packUnorm4x8(vec4(clamp(value.rgb, 0.0, 1.0), 1.0));
    } else {
        out_float[pixel] = value;
        out_rgba8[pixel] = packUnorm4x8(vec4(clamp(abs(value.xyz) * 0.1, 0.0, 1.0), 1.0));
    }
    return min(cost.x + cost.y, 1u << 24);
}

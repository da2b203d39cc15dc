// Scene data as the host packs it (src/tracer/packed.rs holds the Rust twins of these
// structs; the tests compare their layouts with the compiled shader's). All buffers are
// std430.

// EMPTY, the flag bits and the AOV codes: generated from src/contract.rs.
#include "contract.glsl"

// A triangle as the traversal reads it, 40 bytes (load_triangle, load_triangle_halves):
// corner 0, v1 - v0, v2 - v0 (nine floats), then its index in its mesh's file order (uint
// bits). The material is in the shading record, read only at a hit.
struct PackedTriangle {
    vec2 w[5];
};

// A loaded triangle.
struct Triangle {
    vec3 v0;
    vec3 e1;
    vec3 e2;
};

// What the shading reads at a hit: the corners' vertex indices and the material.
struct TriangleShading {
    uvec3 corners;
    uint material;
};

struct Material {
    vec4 diffuse_mirror;     // rgb: Kd, a: mirror strength (scales the blend ratio)
    vec4 specular_shininess; // rgb: Ks, a: Ns
    uvec4 texture;           // x: diffuse texture index or EMPTY, y: flags (TEXTURE_CLAMP, MATERIAL_VERTEX_COLORS)
    vec4 uv_transform;       // xy: scale, zw: offset of the texture coordinates (map_Kd -s, -o)
};

// Two child boxes per node; .w of the four vec4s: left index, left count, right index,
// right count (uint bits). count 0 = inner node, index EMPTY = absent child.
struct BvhNode {
    vec4 left_min;
    vec4 left_max;
    vec4 right_min;
    vec4 right_max;
};

// A placed mesh (src/tracer/records.rs: GpuInstance, 80 bytes).
struct Instance {
    vec4 to_object_x;        // world to object: three rows of a 3x4 matrix
    vec4 to_object_y;
    vec4 to_object_z;
    // x: the binary root (EMPTY: a mesh without triangles), y: triangle base, z: the
    // first wide node in uvec4s (EMPTY: no wide tree), w: the mesh's entry in meshes[]
    uvec4 offsets;
};

// A world-space point and direction in instance `inst`'s mesh space (the direction not
// normalised, so ray parameters stay world distances).
vec3 point_to_object(Instance inst, vec3 p) {
    vec4 h = vec4(p, 1.0);
    return vec3(dot(inst.to_object_x, h), dot(inst.to_object_y, h), dot(inst.to_object_z, h));
}

vec3 vector_to_object(Instance inst, vec3 v) {
    return vec3(dot(inst.to_object_x.xyz, v), dot(inst.to_object_y.xyz, v), dot(inst.to_object_z.xyz, v));
}

// An object-space normal in world space (not normalised): the transpose of the
// world-to-object part, the inverse transpose of the instance's transform.
vec3 normal_to_world(Instance inst, vec3 n) {
    return inst.to_object_x.xyz * n.x + inst.to_object_y.xyz * n.y + inst.to_object_z.xyz * n.z;
}

// World-space area of an object-space parallelogram with (unnormalised) normal `c`:
// |W^T c| / |det W| for the world-to-object part W.
float world_area_of(Instance inst, vec3 c) {
    float det = dot(inst.to_object_x.xyz, cross(inst.to_object_y.xyz, inst.to_object_z.xyz));
    return length(normal_to_world(inst, c)) / abs(det);
}

// Per triangle, in the order of triangles[]: its shading record. Per vertex
// (src/tracer/packed.rs: PackedVertices): the normal (3 floats), texture coordinates and
// RGBA8 colour; the last two are empty when no mesh has them.
layout(std430, set = 0, binding = 1) readonly buffer Shading { TriangleShading shading[]; };
layout(std430, set = 0, binding = 15) readonly buffer VertexNormals { float vertex_normals[]; };
layout(std430, set = 0, binding = 16) readonly buffer VertexTexcoords { vec2 vertex_texcoords[]; };
layout(std430, set = 0, binding = 17) readonly buffer VertexColors { uint vertex_colors[]; };
layout(std430, set = 0, binding = 2) readonly buffer Materials { Material materials[]; };
layout(std430, set = 0, binding = 3) readonly buffer Nodes { BvhNode nodes[]; };
layout(std430, set = 0, binding = 4) readonly buffer Instances { Instance instances[]; };
// The top level: a two-child tree over the instances' world boxes (BvhNode, leaves of one
// instance each, the leaf index an index into instances[]).
layout(std430, set = 0, binding = 20) readonly buffer TopNodes { BvhNode top_nodes[]; };
// Per mesh, what the traversal does not read (src/tracer/records.rs: GpuMesh): x its
// triangle slots (brute force), y its prim-id base, z its convexity (CONVEX_OUTWARD,
// CONVEX_INWARD or 0; tracer/convex.rs).
layout(std430, set = 0, binding = 21) readonly buffer Meshes { uvec4 meshes[]; };
layout(std430, set = 0, binding = 5) buffer OutRgba8 { uint out_rgba8[]; };
layout(std430, set = 0, binding = 6) buffer OutFloat { vec4 out_float[]; };
// All textures' mip chains, RGBA8 (src/tracer/textures.rs), and where each one starts.
layout(std430, set = 0, binding = 7) readonly buffer Texels { uint texels[]; };
layout(std430, set = 0, binding = 8) readonly buffer TextureInfos { uvec4 texture_infos[]; }; // offset, w, h, levels
// Primary-hit ids of the adaptive pre-pass (one per pixel).
layout(std430, set = 0, binding = 9) buffer PrimIds { uint prim_ids[]; };
// Per pixel, the copy its camera ray hit in the last frame (EMPTY for a miss or none), where
// the top level's walk starts (intersect.glsl, closest_hit).
layout(std430, set = 0, binding = 22) buffer WalkHints { uint walk_hints[]; };
// Equirectangular environment: [0] width, [1] height, then RGB9E5 (HDR) texels.
layout(std430, set = 0, binding = 10) readonly buffer Environment { uint environment[]; };

// The triangles (src/tracer/packed.rs: GpuTriangle), read two ways. As 8-byte halves:
// the binary traversal's leaves (test_leaves), which load up to four triangles ahead and
// were 3-15% slower on the H100 with the 16-byte words' selects and registers.
layout(std430, set = 0, binding = 19) readonly buffer TriangleHalves { PackedTriangle triangles[]; };

Triangle load_triangle_halves(uint k) {
    vec2 a = triangles[k].w[0], b = triangles[k].w[1], c = triangles[k].w[2], d = triangles[k].w[3], e = triangles[k].w[4];
    return Triangle(vec3(a, b.x), vec3(b.y, c), vec3(d, e.x));
}

// As 16-byte words: everything else, a triangle in three loads and a wide leaf's first two
// in five or six, where the halves take five and ten (the wide traversal 2% faster on the
// 16M knot, AO 6%). Triangle k starts at word 5k/2, at the word's start for k even and 8
// bytes into it for k odd. The buffer ends in TRIANGLE_READ_AHEAD bytes of padding, which
// the loads may read past the last triangle.
layout(std430, set = 0, binding = 0) readonly buffer Triangles { uvec4 triangle_words[]; };

// The triangle starting in word a, 8 bytes into it (`shifted`) or at its start; b and c
// the words after a.
Triangle triangle_from_words(uvec4 a, uvec4 b, uvec4 c, bool shifted) {
    vec4 fa = uintBitsToFloat(a), fb = uintBitsToFloat(b), fc = uintBitsToFloat(c);
    vec3 v0 = shifted ? vec3(fa.zw, fb.x) : fa.xyz;
    vec3 e1 = shifted ? fb.yzw : vec3(fa.w, fb.xy);
    vec3 e2 = shifted ? fc.xyz : vec3(fb.zw, fc.x);
    return Triangle(v0, e1, e2);
}

Triangle load_triangle(uint k) {
    uint m = (5u * k) >> 1u;
    return triangle_from_words(triangle_words[m], triangle_words[m + 1u], triangle_words[m + 2u], (k & 1u) != 0u);
}

// Triangles k and k + 1 (the second unused when a leaf has one; its words may then be the
// padding's).
void load_triangle_pair(uint k, out Triangle t0, out Triangle t1) {
    uint m = (5u * k) >> 1u;
    bool odd = (k & 1u) != 0u;
    uvec4 a = triangle_words[m], b = triangle_words[m + 1u], c = triangle_words[m + 2u];
    uvec4 d = triangle_words[m + 3u], e = triangle_words[m + 4u];
    uvec4 f = odd ? triangle_words[m + 5u] : uvec4(0u);
    t0 = triangle_from_words(a, b, c, odd);
    // k + 1 starts 8 bytes into word c (k even) or at word d (k odd).
    t1 = odd ? triangle_from_words(d, e, f, false) : triangle_from_words(c, d, e, true);
}

// Triangle k's index in its mesh's file order.
uint triangle_prim(uint k) {
    uvec4 w = triangle_words[((5u * k) >> 1u) + 2u];
    return (k & 1u) != 0u ? w.w : w.y;
}

vec3 vertex_normal(uint k) {
    return vec3(vertex_normals[3u * k], vertex_normals[3u * k + 1u], vertex_normals[3u * k + 2u]);
}

// Per-frame parameters (src/tracer/frame.rs: FrameParams::push_constants). 128 bytes.
layout(push_constant) uniform Frame {
    vec4 cam_origin_eps;     // xyz: camera position, w: ray offset epsilon
    vec4 cam_forward_blend;  // xyz: forward, w: reflection blend ratio
    vec4 cam_right_ambient;  // xyz: right * tan(fov/2) * aspect, w: ambient fraction
    vec4 cam_up;             // xyz: up * tan(fov/2), w: trace.comp's tile_base (uint bits)
    vec4 light_pos;          // xyz: point light position, w: AO radius (the AO view)
    vec4 light_color;        // rgb: light colour, w: AO rays per hit (uint bits)
    // z: bounces (bits 0-7, BOUNCES_MASK), then the band's lanes: its first lane (bits
    // 8-15) and span (bits 16-23), so a band finer than a work group traces lanes
    // first..=first + span of its group (in_band); first 0 and span 255 for every other
    // band. w: flags.
    uvec4 dims;              // width, height, bounces and band lanes, flags
    uvec4 misc;              // instance count (0: trace nothing), first row of this dispatch, background (rgba8), accumulated frames
} frame;

const float INF = 1e30;

// A closest hit: distance along the ray, barycentrics of corners 1 and 2, the triangle
// (global index into triangles[]; EMPTY for none) and its instance.
struct Hit {
    float t;
    float u;
    float v;
    uint tri;
    uint instance;
};

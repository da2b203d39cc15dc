#version 460
#extension GL_EXT_ray_query : require
// The tracer with the driver's traversal from the compute shader (VK_KHR_ray_query): the
// same pixels, shading and outputs as trace.comp, only closest_hit differs.

// The work group must be trace.comp's: both are recorded by the same dispatch.
layout(local_size_x = 32, local_size_y = 4, local_size_z = 1) in;

#include "../scene.glsl"
#include "tlas.glsl"

// `use_bvh`, `skip` and `cost` are our traversal's: the driver's has no cost to report, and
// the instance `skip` names holds no hit for the ray anyway (tracer/convex.rs).
Hit closest_hit(vec3 o, vec3 d, bool use_bvh, uint skip, inout uvec2 cost) {
    rayQueryEXT query;
    rayQueryInitializeEXT(query, scene_tlas, VENDOR_RAY_FLAGS, 0xFFu, o, 0.0, d, INF);
    while (rayQueryProceedEXT(query)) {
    }
    if (rayQueryGetIntersectionTypeEXT(query, true) != gl_RayQueryCommittedIntersectionTriangleEXT) return no_hit();
    return vendor_hit(rayQueryGetIntersectionTEXT(query, true), rayQueryGetIntersectionBarycentricsEXT(query, true),
                      rayQueryGetIntersectionInstanceCustomIndexEXT(query, true),
                      rayQueryGetIntersectionPrimitiveIndexEXT(query, true));
}

// The AO view's occlusion query: the driver stops at the first hit it meets within t_max
// (any triangle will do, so no closest one is searched for).
bool any_hit(vec3 o, vec3 d, float t_max, bool use_bvh, uint skip, inout uvec2 cost) {
    rayQueryEXT query;
    rayQueryInitializeEXT(query, scene_tlas, VENDOR_RAY_FLAGS | gl_RayFlagsTerminateOnFirstHitEXT, 0xFFu, o, 0.0, d, t_max);
    while (rayQueryProceedEXT(query)) {
    }
    return rayQueryGetIntersectionTypeEXT(query, true) != gl_RayQueryCommittedIntersectionNoneEXT;
}

#include "../trace.glsl"

void main() {
    if (!in_band(gl_LocalInvocationIndex)) return;
    trace_pixel(uvec2(gl_GlobalInvocationID.x, gl_GlobalInvocationID.y + frame.misc.y));
}

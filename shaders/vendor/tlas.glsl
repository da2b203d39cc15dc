// The driver's acceleration structure over the scene (src/gpu/vendor/accel.rs): one
// bottom level per mesh, an instance per model copy and mirror plane, each instance's
// custom index its place in instances[] and its primitives in the order of triangles[].
layout(set = 0, binding = 11) uniform accelerationStructureEXT scene_tlas;

// Opaque geometry (no any-hit shaders), both faces hit as our tracer does.
const uint VENDOR_RAY_FLAGS = gl_RayFlagsOpaqueEXT;

// A hit as the driver reports it, in our terms: the triangle's global index is the
// instance's first triangle plus the primitive index within its mesh.
Hit vendor_hit(float t, vec2 barycentrics, uint instance, uint primitive) {
    Hit hit;
    hit.t = t;
    hit.u = barycentrics.x;
    hit.v = barycentrics.y;
    hit.instance = instance;
    hit.tri = instances[instance].offsets.y + primitive;
    return hit;
}

Hit no_hit() {
    Hit hit;
    hit.t = INF;
    hit.u = 0.0;
    hit.v = 0.0;
    hit.tri = EMPTY;
    hit.instance = EMPTY;
    return hit;
}

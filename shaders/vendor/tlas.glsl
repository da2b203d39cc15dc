// The driver's acceleration structure over the scene (src/gpu/khr_rt/accel.rs): one
// bottom level per mesh, an instance per model copy and mirror plane, each instance's
// custom index its place in instances[] and its primitives the mesh's triangles in the
// order of triangles[], each once (vendor_slots below).
layout(set = 0, binding = TLAS_BINDING) uniform accelerationStructureEXT scene_tlas;

// Which of our slots each primitive is (src/gpu/khr_rt/accel.rs): a triangle our build
// cut fills several slots but is given to the driver once. Word 0 is 1 where some mesh is
// cut, then word 1 + base + k is the slot of primitive k of the mesh starting at slot
// `base`; where word 0 is 0, primitive k is slot k.
layout(std430, set = 0, binding = VENDOR_SLOTS_BINDING) readonly buffer VendorSlots { uint vendor_slots[]; };

// Opaque geometry (no any-hit shaders), both faces hit as our tracer does.
const uint VENDOR_RAY_FLAGS = gl_RayFlagsOpaqueEXT;

// A hit as the driver reports it, in our terms: the triangle's global index is the
// instance's first triangle plus the slot of the primitive within its mesh.
Hit vendor_hit(float t, vec2 barycentrics, uint instance, uint primitive) {
    Hit hit;
    hit.t = t;
    hit.u = barycentrics.x;
    hit.v = barycentrics.y;
    hit.instance = instance;
    uint base = instances[instance].offsets.y;
    hit.tri = base + (vendor_slots[0] != 0u ? vendor_slots[1u + base + primitive] : primitive);
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

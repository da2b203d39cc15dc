#version 460
#extension GL_EXT_ray_tracing : require
// The closest hit of a ray: where, and on which primitive of which instance.

#include "payload.glsl"

layout(location = 0) rayPayloadInEXT RayPayload payload;
hitAttributeEXT vec2 barycentrics;

void main() {
    payload.t = gl_HitTEXT;
    payload.barycentrics = barycentrics;
    payload.instance = uint(gl_InstanceCustomIndexEXT);
    payload.primitive = uint(gl_PrimitiveID);
}

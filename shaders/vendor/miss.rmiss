#version 460
#extension GL_EXT_ray_tracing : require
// A ray that hits nothing.

#include "payload.glsl"

layout(location = 0) rayPayloadInEXT RayPayload payload;

void main() {
    payload.instance = 0xffffffffu;
}

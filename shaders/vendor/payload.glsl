// What the closest-hit and miss shaders hand back to the ray generation shader.
struct RayPayload {
    float t;
    vec2 barycentrics;
    uint instance;   // 0xffffffff: the ray missed
    uint primitive;
};

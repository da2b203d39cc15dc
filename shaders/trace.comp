#version 450
// The tracer (paper 3.3): one invocation per pixel; a primary ray through the pixel
// centre, the closest hit, Blinn–Phong at the hit, then mirror bounces blended with the
// colour so far at the reflection ratio. The CPU twin is src/tracer/cpu.rs.

layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

#include "scene.glsl"
#include "intersect.glsl"
#include "shade.glsl"

void main() {
    uint width = frame.dims.x;
    uint height = frame.dims.y;
    uvec2 px = uvec2(gl_GlobalInvocationID.x, gl_GlobalInvocationID.y + frame.misc.y);
    if (px.x >= width || px.y >= height) return;

    vec2 ndc = vec2((float(px.x) + 0.5) / float(width) * 2.0 - 1.0,
                    1.0 - (float(px.y) + 0.5) / float(height) * 2.0);
    vec3 o = frame.cam_origin_eps.xyz;
    vec3 d = normalize(frame.cam_forward_blend.xyz + ndc.x * frame.cam_right_ambient.xyz + ndc.y * frame.cam_up.xyz);

    uint flags = frame.dims.w;
    bool use_bvh = (flags & FLAG_BVH) != 0u;
    uint aov = (flags >> AOV_SHIFT) & 7u;
    uint bounces = (aov == AOV_COLOR || aov == AOV_COST) ? frame.dims.z : 0u;
    float blend = frame.cam_forward_blend.w;
    float eps = frame.cam_origin_eps.w;
    vec3 background = unpackUnorm4x8(frame.misc.z).rgb;

    vec3 color = vec3(0.0);
    vec3 throughput = vec3(1.0);
    vec4 aux = vec4(-1.0, -1.0, -1.0, 0.0);
    uvec2 cost = uvec2(0u);

    for (uint bounce = 0u; bounce <= bounces; bounce++) {
        Hit hit = closest_hit(o, d, use_bvh, cost);
        if (hit.tri == EMPTY) {
            color += throughput * background;
            if (bounce == 0u && aov == AOV_NORMAL) aux = vec4(0.0);
            break;
        }
        Triangle tri = triangles[hit.tri];
        vec3 p = o + d * hit.t;
        vec3 n = normalize(cross(tri.e1.xyz, tri.e2.xyz));
        if (dot(n, d) > 0.0) n = -n;  // two-sided: face the incoming ray
        uint mat_index = floatBitsToUint(tri.v0.w);
        Material mat = materials[mat_index];
        vec3 local_color = blinn_phong(mat, p, n, -d);
        if (bounce == 0u) {
            uint prim = floatBitsToUint(tri.e1.w) + instances[hit.instance].offsets.w;
            if (aov == AOV_DEPTH) aux = vec4(hit.t, hit.t, hit.t, 1.0);
            if (aov == AOV_NORMAL) aux = vec4(n, 1.0);
            if (aov == AOV_PRIM_ID) aux = vec4(float(prim), float(prim), float(prim), 1.0);
        }
        float r = blend * mat.diffuse_mirror.a;
        if (bounce == bounces) {
            color += throughput * local_color;
            break;
        }
        // mix(local, reflected, r): the local part now, the reflected part next bounce.
        color += throughput * (1.0 - r) * local_color;
        throughput *= r;
        if (r <= 0.0) break;
        o = p + n * eps;
        d = reflect(d, n);
    }

    uint pixel = px.y * width + px.x;
    if (aov == AOV_COLOR) {
        out_float[pixel] = vec4(color, 1.0);
        out_rgba8[pixel] = packUnorm4x8(vec4(clamp(color, 0.0, 1.0), 1.0));
    } else if (aov == AOV_COST) {
        out_float[pixel] = vec4(float(cost.x), float(cost.y), 0.0, 1.0);
        out_rgba8[pixel] = packUnorm4x8(vec4(clamp(color, 0.0, 1.0), 1.0));
    } else {
        out_float[pixel] = aux;
        out_rgba8[pixel] = packUnorm4x8(vec4(clamp(abs(aux.xyz) * 0.1, 0.0, 1.0), 1.0));
    }
}

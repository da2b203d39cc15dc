// Blinn–Phong at a hit (paper 3.3 step 3): ambient + diffuse + specular from one point
// light where `lit` says it reaches the hit (light_reaches below). `ns` is the shading
// normal facing the viewer. Mirrors src/tracer/shading.rs.

vec3 blinn_phong(vec3 kd, Material mat, vec3 l, vec3 ns, bool lit, vec3 to_eye) {
    vec3 ks = mat.specular_shininess.rgb;
    float ns_exp = mat.specular_shininess.a;
    float ndl = lit ? max(dot(ns, l), 0.0) : 0.0;
    float spec = 0.0;
    if (ndl > 0.0) {
        vec3 h = normalize(l + to_eye);
        spec = pow(max(dot(ns, h), 0.0), ns_exp);
    }
    return kd * frame.cam_right_ambient.w + frame.light_color.rgb * (kd * ndl + ks * spec);
}

// Hanika, "Hacking the shadow terminator" (Ray Tracing Gems II, ch. 4): the hit at
// barycentrics (u, v) moved out to the tangent planes of the three corners (each corner's
// plane through it with its normal n0..n2; only the outward part of each projection),
// blended with the barycentrics. The offset from the hit point, in object space.
vec3 terminator_offset(float u, float v, vec3 e1, vec3 e2, vec3 n0, vec3 n1, vec3 n2) {
    float w = 1.0 - u - v;
    vec3 rel0 = e1 * u + e2 * v;
    vec3 rel1 = e1 * (u - 1.0) + e2 * v;
    vec3 rel2 = e1 * u + e2 * (v - 1.0);
    vec3 offset = vec3(0.0);
    if (dot(n0, n0) > 1e-12) {
        vec3 n = normalize(n0);
        offset -= n * (min(dot(rel0, n), 0.0) * w);
    }
    if (dot(n1, n1) > 1e-12) {
        vec3 n = normalize(n1);
        offset -= n * (min(dot(rel1, n), 0.0) * u);
    }
    if (dot(n2, n2) > 1e-12) {
        vec3 n = normalize(n2);
        offset -= n * (min(dot(rel2, n), 0.0) * v);
    }
    return offset;
}

// Whether the segment from the offset hit point to the light (to_light, object space, the
// light at parameter 1) passes through the hit triangle itself; a crossing behind the
// origin counts too.
bool shadows_itself(float u, float v, vec3 e1, vec3 e2, vec3 offset, vec3 to_light) {
    vec3 p = cross(to_light, e2);
    float det = dot(e1, p);
    if (abs(det) < 1e-12) return false;
    float inv = 1.0 / det;
    vec3 tv = e1 * u + e2 * v + offset;
    float a = dot(tv, p) * inv;
    if (a < 0.0 || a > 1.0) return false;
    vec3 q = cross(tv, e1);
    float b = dot(to_light, q) * inv;
    if (b < 0.0 || a + b > 1.0) return false;
    return dot(e2, q) * inv < 1.0;
}

// Whether the point light reaches a hit. No shadow rays against the rest of the scene (the
// paper): the only occluder is the hit triangle, so light behind its plane (ng, facing the
// viewer) is blocked and smooth normals cannot leak it through silhouettes. A smoothly
// shaded hit (smooth_hit) that ns says is lit starts that self-shadow test from Hanika's
// offset point, so the terminator follows the smooth normals, not the flat triangles.
// Everything in the mesh's space: l the direction to the light (not normalised), p the
// hit, light the light's position, n0..n2 the corner normals on the viewer's side.
bool light_reaches(vec3 l, vec3 ng, vec3 ns, bool smooth_hit, float u, float v, vec3 e1, vec3 e2,
                   vec3 n0, vec3 n1, vec3 n2, vec3 p, vec3 light) {
    if (dot(ng, l) > 0.0) return true;
    if (!smooth_hit) return false;
    if (dot(ns, l) <= 0.0) return false;
    vec3 offset = terminator_offset(u, v, e1, e2, n0, n1, n2);
    return !shadows_itself(u, v, e1, e2, offset, light - (p + offset));
}

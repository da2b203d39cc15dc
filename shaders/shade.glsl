// Blinn–Phong at a hit (paper 3.3 step 3): ambient + diffuse + specular from one point
// light, no shadow rays (as in the paper). `ns` is the shading normal, `ng` the geometric
// one (both facing the viewer): light from behind the geometric surface does not leak
// through smooth-shaded silhouettes. Mirrors src/tracer/shading.rs.

vec3 blinn_phong(vec3 kd, Material mat, vec3 p, vec3 ns, vec3 ng, vec3 to_eye) {
    vec3 ks = mat.specular_shininess.rgb;
    float ns_exp = mat.specular_shininess.a;
    vec3 l = normalize(frame.light_pos.xyz - p);
    float ndl = dot(ng, l) > 0.0 ? max(dot(ns, l), 0.0) : 0.0;
    float spec = 0.0;
    if (ndl > 0.0) {
        vec3 h = normalize(l + to_eye);
        spec = pow(max(dot(ns, h), 0.0), ns_exp);
    }
    return kd * frame.cam_right_ambient.w + frame.light_color.rgb * (kd * ndl + ks * spec);
}

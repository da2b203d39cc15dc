// Blinn–Phong at a hit (paper 3.3 step 3): ambient + diffuse + specular from one point
// light, no shadow rays (as in the paper). Mirrors src/tracer/shading.rs.

vec3 blinn_phong(Material mat, vec3 p, vec3 n, vec3 to_eye) {
    vec3 kd = mat.diffuse_mirror.rgb;
    vec3 ks = mat.specular_shininess.rgb;
    float ns = mat.specular_shininess.a;
    vec3 l = normalize(frame.light_pos.xyz - p);
    float ndl = max(dot(n, l), 0.0);
    float spec = 0.0;
    if (ndl > 0.0) {
        vec3 h = normalize(l + to_eye);
        spec = pow(max(dot(n, h), 0.0), ns);
    }
    return kd * frame.cam_right_ambient.w + frame.light_color.rgb * (kd * ndl + ks * spec);
}

// Texture filtering, the twin of TextureAtlas::sample_with (src/tracer/textures.rs):
// bilinear within a mip level, linear between levels, repeat wrap (or clamp to the edge
// texels), v = 0 at the image bottom.

vec4 fetch_texel(uvec4 info, uint level, ivec2 p, bool clamped) {
    uint base = info.x;
    for (uint k = 0u; k < level; k++) {
        base += max(info.y >> k, 1u) * max(info.z >> k, 1u);
    }
    int lw = int(max(info.y >> level, 1u));
    int lh = int(max(info.z >> level, 1u));
    int x = clamped ? clamp(p.x, 0, lw - 1) : ((p.x % lw) + lw) % lw;
    int y = clamped ? clamp(p.y, 0, lh - 1) : ((p.y % lh) + lh) % lh;
    return unpackUnorm4x8(texels[base + uint(y * lw + x)]);
}

vec4 bilinear(uvec4 info, uint level, vec2 uv, bool clamped) {
    float lw = float(max(info.y >> level, 1u));
    float lh = float(max(info.z >> level, 1u));
    vec2 p = vec2(uv.x * lw - 0.5, (1.0 - uv.y) * lh - 0.5);
    vec2 f = floor(p);
    vec2 t = p - f;
    ivec2 i = ivec2(f);
    vec4 a = mix(fetch_texel(info, level, i, clamped), fetch_texel(info, level, i + ivec2(1, 0), clamped), t.x);
    vec4 b = mix(fetch_texel(info, level, i + ivec2(0, 1), clamped), fetch_texel(info, level, i + ivec2(1, 1), clamped), t.x);
    return mix(a, b, t.y);
}

vec4 sample_texture(uint index, vec2 uv, float lod, bool clamped) {
    uvec4 info = texture_infos[index];
    if (clamped) uv = clamp(uv, vec2(0.0), vec2(1.0));
    lod = clamp(lod, 0.0, float(info.w - 1u));
    float l0 = floor(lod);
    vec4 c0 = bilinear(info, uint(l0), uv, clamped);
    if (lod > l0) {
        c0 = mix(c0, bilinear(info, uint(l0) + 1u, uv, clamped), lod - l0);
    }
    return c0;
}

// The texture coordinates a material's texture is looked up at: the surface's scaled
// and offset (map_Kd -s, -o; GpuMaterial::texture_uv).
vec2 material_uv(Material mat, vec2 uv) {
    return uv * mat.uv_transform.xy + mat.uv_transform.zw;
}

// A material's diffuse texture at `uv` (already through material_uv), repeating or clamped
// as the material says.
vec4 sample_material_texture(Material mat, vec2 uv, float lod) {
    return sample_texture(mat.texture.x, uv, lod, (mat.texture.y & TEXTURE_CLAMP) != 0u);
}

// Shared-exponent HDR texel: 9-bit mantissas, 5-bit exponent (EnvironmentMap in
// src/tracer/textures.rs encodes it).
vec3 decode_rgb9e5(uint v) {
    // ldexp, unlike exp2, is exact on every device.
    int e = int(v >> 27) - 15 - 9;
    return ldexp(vec3(float(v & 511u), float((v >> 9) & 511u), float((v >> 18) & 511u)), ivec3(e));
}

// Environment: bilinear, u wraps around, v clamps at the poles.
vec3 environment_texel(ivec2 p, int w, int h) {
    int x = ((p.x % w) + w) % w;
    int y = clamp(p.y, 0, h - 1);
    return decode_rgb9e5(environment[2 + uint(y * w + x)]);
}

vec3 sample_environment(vec3 d) {
    int w = int(environment[0]);
    int h = int(environment[1]);
    const float PI = 3.14159265358979;
    float u = 0.5 + atan(d.z, d.x) * (0.5 / PI);
    float v = 1.0 - acos(clamp(d.y, -1.0, 1.0)) / PI;
    vec2 p = vec2(u * float(w) - 0.5, (1.0 - v) * float(h) - 0.5);
    vec2 f = floor(p);
    vec2 t = p - f;
    ivec2 i = ivec2(f);
    vec3 a = mix(environment_texel(i, w, h), environment_texel(i + ivec2(1, 0), w, h), t.x);
    vec3 b = mix(environment_texel(i + ivec2(0, 1), w, h), environment_texel(i + ivec2(1, 1), w, h), t.x);
    return mix(a, b, t.y);
}

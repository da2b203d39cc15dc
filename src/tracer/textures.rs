//! Textures for both tracers: every diffuse map packed into one array of RGBA8 texels with
//! a full mip chain per image, addressed by `TextureInfo`, and the environment map in
//! shared-exponent HDR texels. One storage buffer serves any number of textures on any driver; the
//! shader (`shaders/texture.glsl`) and [`TextureAtlas::sample`] filter identically.

use std::path::Path;

use glam::{Vec2, Vec3, Vec4};

/// Where one texture's texels live: offset of level 0, size, mip level count.
pub(crate) type TextureInfo = [u32; 4];

/// All textures of a scene, mip-mapped, in one texel array.
#[derive(Clone, Debug, Default)]
pub struct TextureAtlas {
    /// RGBA8 texels, little-endian packed (R in the low byte) as `unpackUnorm4x8` reads them.
    pub(crate) texels: Vec<u32>,
    pub infos: Vec<TextureInfo>,
}

fn level_size(w: u32, h: u32, level: u32) -> (u32, u32) {
    ((w >> level).max(1), (h >> level).max(1))
}

fn pack(c: [u8; 4]) -> u32 {
    u32::from_le_bytes(c)
}

fn unpack(v: u32) -> Vec4 {
    let b = v.to_le_bytes();
    Vec4::new(b[0] as f32, b[1] as f32, b[2] as f32, b[3] as f32) / 255.0
}

impl TextureAtlas {
    /// Add an image with its mip chain (2x2 box filter); returns its index.
    pub fn add(&mut self, image: &image::RgbaImage) -> u32 {
        let (w, h) = image.dimensions();
        let levels = 32 - w.max(h).max(1).leading_zeros();
        let offset = self.texels.len() as u32;
        let mut level: Vec<[u8; 4]> = image.pixels().map(|p| p.0).collect();
        let (mut lw, mut lh) = (w, h);
        for k in 0..levels {
            self.texels.extend(level.iter().map(|&c| pack(c)));
            if k + 1 == levels {
                break;
            }
            let (nw, nh) = level_size(w, h, k + 1);
            let mut next = Vec::with_capacity((nw * nh) as usize);
            for y in 0..nh {
                for x in 0..nw {
                    let mut sum = [0u32; 4];
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let sx = (2 * x + dx).min(lw - 1);
                        let sy = (2 * y + dy).min(lh - 1);
                        let c = level[(sy * lw + sx) as usize];
                        for i in 0..4 {
                            sum[i] += c[i] as u32;
                        }
                    }
                    next.push(sum.map(|s| ((s + 2) / 4) as u8));
                }
            }
            level = next;
            (lw, lh) = (nw, nh);
        }
        self.infos.push([offset, w, h, levels]);
        (self.infos.len() - 1) as u32
    }

    fn fetch(&self, info: &TextureInfo, level: u32, x: i32, y: i32, clamped: bool) -> Vec4 {
        let [offset, w, h, _] = *info;
        let mut base = offset;
        for k in 0..level {
            let (lw, lh) = level_size(w, h, k);
            base += lw * lh;
        }
        let (lw, lh) = level_size(w, h, level);
        let (xi, yi) = if clamped {
            (x.clamp(0, lw as i32 - 1) as u32, y.clamp(0, lh as i32 - 1) as u32)
        } else {
            (x.rem_euclid(lw as i32) as u32, y.rem_euclid(lh as i32) as u32)
        };
        unpack(self.texels[(base + yi * lw + xi) as usize])
    }

    fn bilinear(&self, info: &TextureInfo, level: u32, uv: Vec2, clamped: bool) -> Vec4 {
        let (lw, lh) = level_size(info[1], info[2], level);
        // v = 0 is the bottom of the image (OBJ convention): flip to rows.
        let p = Vec2::new(uv.x * lw as f32 - 0.5, (1.0 - uv.y) * lh as f32 - 0.5);
        let f = p.floor();
        let t = p - f;
        let (x, y) = (f.x as i32, f.y as i32);
        let a = self
            .fetch(info, level, x, y, clamped)
            .lerp(self.fetch(info, level, x + 1, y, clamped), t.x);
        let b = self
            .fetch(info, level, x, y + 1, clamped)
            .lerp(self.fetch(info, level, x + 1, y + 1, clamped), t.x);
        a.lerp(b, t.y)
    }

    /// Trilinear sample of texture `index` at `uv` (repeat wrap) and mip level `lod`.
    pub fn sample(&self, index: u32, uv: Vec2, lod: f32) -> Vec4 {
        self.sample_with(index, uv, lod, false)
    }

    /// Trilinear sample of texture `index` at `uv` and mip level `lod`; with `clamped`,
    /// `uv` clamps to [0, 1] and the filter to the edge texels instead of repeating (the
    /// shader's `sample_texture`).
    pub fn sample_with(&self, index: u32, uv: Vec2, lod: f32, clamped: bool) -> Vec4 {
        let info = &self.infos[index as usize];
        let uv = if clamped { uv.clamp(Vec2::ZERO, Vec2::ONE) } else { uv };
        let lod = lod.clamp(0.0, (info[3] - 1) as f32);
        let l0 = lod.floor();
        let c0 = self.bilinear(info, l0 as u32, uv, clamped);
        if lod > l0 {
            c0.lerp(self.bilinear(info, l0 as u32 + 1, uv, clamped), lod - l0)
        } else {
            c0
        }
    }
}

/// Direction -> equirectangular texture coordinates (u around +y from +x, v = 1 at the zenith).
pub fn direction_to_equirect(d: Vec3) -> Vec2 {
    let u = 0.5 + d.z.atan2(d.x) * (0.5 / std::f32::consts::PI);
    let v = 1.0 - d.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
    Vec2::new(u, v)
}

/// The default environment, made in code: a sky gradient over a darker ground with a
/// horizon glow, as an equirectangular image.
pub fn sky_image(width: u32, height: u32) -> image::RgbaImage {
    image::RgbaImage::from_fn(width, height, |_, y| {
        let elevation = 0.5 - (y as f32 + 0.5) / height as f32; // +0.5 zenith, -0.5 nadir
        let c = if elevation >= 0.0 {
            let t = (elevation * 2.0).powf(0.6);
            Vec3::new(0.85, 0.9, 1.0).lerp(Vec3::new(0.25, 0.45, 0.85), t)
        } else {
            let t = (-elevation * 2.0).powf(0.5);
            Vec3::new(0.45, 0.42, 0.38).lerp(Vec3::new(0.18, 0.16, 0.14), t)
        };
        let c = (c * 255.0).round();
        image::Rgba([c.x as u8, c.y as u8, c.z as u8, 255])
    })
}

/// An equirectangular environment map in high dynamic range: one shared-exponent RGB9E5
/// word per texel (9-bit mantissas, 5-bit exponent, as GPUs store HDR textures), so an
/// HDR or EXR sky keeps its bright sun at the size of an 8-bit image. Row 0 is the zenith.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentMap {
    pub(crate) width: u32,
    pub(crate) height: u32,
    /// RGB9E5 texels, row-major ([`encode_rgb9e5`]).
    pub(crate) texels: Vec<u32>,
}

/// Mantissa bits, exponent bias and the largest value of RGB9E5 (EXT_texture_shared_exponent).
const RGB9E5_MANTISSA_BITS: i32 = 9;
const RGB9E5_BIAS: i32 = 15;
/// The largest value RGB9E5 holds; brighter texels are clamped to it.
pub(crate) const RGB9E5_MAX: f32 = 65408.0;

/// Encode a linear RGB value as RGB9E5 (negative and NaN become 0, values above
/// [`RGB9E5_MAX`] are clamped). Each channel keeps 9 bits relative to the largest one.
pub(crate) fn encode_rgb9e5(c: Vec3) -> u32 {
    let clamp = |x: f32| if x.is_nan() { 0.0 } else { x.clamp(0.0, RGB9E5_MAX) };
    let (r, g, b) = (clamp(c.x), clamp(c.y), clamp(c.z));
    let max = r.max(g).max(b);
    if max == 0.0 {
        return 0;
    }
    let mut exp = (max.log2().floor() as i32).max(-RGB9E5_BIAS - 1) + 1 + RGB9E5_BIAS;
    let mut scale = 2f32.powi(exp - RGB9E5_BIAS - RGB9E5_MANTISSA_BITS);
    if (max / scale + 0.5).floor() as u32 == 1 << RGB9E5_MANTISSA_BITS {
        exp += 1;
        scale *= 2.0;
    }
    let m = |x: f32| ((x / scale + 0.5).floor() as u32).min(511);
    m(r) | (m(g) << 9) | (m(b) << 18) | ((exp as u32) << 27)
}

/// Decode an RGB9E5 word (exact in f32; the shader's `decode_rgb9e5`).
pub(crate) fn decode_rgb9e5(v: u32) -> Vec3 {
    let scale = 2f32.powi((v >> 27) as i32 - RGB9E5_BIAS - RGB9E5_MANTISSA_BITS);
    Vec3::new((v & 511) as f32, ((v >> 9) & 511) as f32, ((v >> 18) & 511) as f32) * scale
}

impl EnvironmentMap {
    /// From an 8-bit image (values / 255, as the tracer reads colours).
    pub(crate) fn from_rgba8(img: &image::RgbaImage) -> Self {
        let texels = img
            .pixels()
            .map(|p| encode_rgb9e5(Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32) / 255.0))
            .collect();
        Self { width: img.width(), height: img.height(), texels }
    }

    /// The default sky (`--env sky`, and the fallback for an unreadable file): [`sky_image`]
    /// at 512x256.
    pub(crate) fn generated_sky() -> Self {
        Self::from_rgba8(&sky_image(512, 256))
    }

    /// The map `source` names (None: no environment). A file that cannot be read falls
    /// back to the generated sky, with the warning returned.
    pub(crate) fn from_source(
        source: Option<&crate::scene::EnvironmentSource>,
    ) -> (Option<Self>, Option<String>) {
        use crate::scene::EnvironmentSource;
        match source {
            None => (None, None),
            Some(EnvironmentSource::Sky) => (Some(Self::generated_sky()), None),
            Some(EnvironmentSource::File(path)) => match load_environment(path) {
                Ok(map) => (Some(map), None),
                Err(e) => (
                    Some(Self::generated_sky()),
                    Some(format!("{e}; using the generated sky instead")),
                ),
            },
        }
    }

    /// From linear floating-point texels (HDR, EXR).
    pub(crate) fn from_rgba32f(img: &image::Rgba32FImage) -> Self {
        let texels = img.pixels().map(|p| encode_rgb9e5(Vec3::new(p[0], p[1], p[2]))).collect();
        Self { width: img.width(), height: img.height(), texels }
    }

    /// Texel (x, y): x wraps around, y clamps at the poles.
    pub(crate) fn texel(&self, x: i32, y: i32) -> Vec3 {
        let (w, h) = (self.width as i32, self.height as i32);
        decode_rgb9e5(self.texels[(y.clamp(0, h - 1) * w + x.rem_euclid(w)) as usize])
    }

    /// Bilinear sample in direction `d` (the shader's `sample_environment`).
    pub(crate) fn sample(&self, d: Vec3) -> Vec3 {
        let uv = direction_to_equirect(d);
        let p = Vec2::new(uv.x * self.width as f32 - 0.5, (1.0 - uv.y) * self.height as f32 - 0.5);
        let f = p.floor();
        let t = p - f;
        let (x, y) = (f.x as i32, f.y as i32);
        let a = self.texel(x, y).lerp(self.texel(x + 1, y), t.x);
        let b = self.texel(x, y + 1).lerp(self.texel(x + 1, y + 1), t.x);
        a.lerp(b, t.y)
    }
}

/// Load an equirectangular environment image: PNG and JPEG as 8-bit values / 255, HDR and
/// EXR as their linear floating-point values (brighter than 1 stays brighter; see
/// [`EnvironmentMap`]).
pub(crate) fn load_environment(path: &Path) -> anyhow::Result<EnvironmentMap> {
    let img = crate::files::read_image(path, "environment map").map_err(anyhow::Error::msg)?;
    Ok(match img {
        image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_) => {
            EnvironmentMap::from_rgba32f(&img.to_rgba32f())
        }
        _ => EnvironmentMap::from_rgba8(&img.to_rgba8()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker(n: u32) -> image::RgbaImage {
        image::RgbaImage::from_fn(n, n, |x, y| {
            if (x + y) % 2 == 0 {
                image::Rgba([255, 0, 0, 255])
            } else {
                image::Rgba([0, 0, 255, 255])
            }
        })
    }

    #[test]
    fn mip_chain_averages_down_to_one_texel() {
        let mut atlas = TextureAtlas::default();
        let i = atlas.add(&checker(4));
        assert_eq!(atlas.infos[i as usize][3], 3); // 4x4, 2x2, 1x1
        assert_eq!(atlas.texels.len(), 16 + 4 + 1);
        let top = atlas.sample(i, Vec2::new(0.3, 0.3), 2.0);
        assert!((top - Vec4::new(0.5, 0.0, 0.5, 1.0)).abs().max_element() < 0.01, "{top}");
    }

    #[test]
    fn texel_centres_sample_exactly() {
        let mut atlas = TextureAtlas::default();
        let i = atlas.add(&checker(4));
        // Texel (0, 3) (bottom-left in uv) is red: (0 + 3) odd -> blue. Check both parities.
        let c = atlas.sample(i, Vec2::new(0.125, 0.125), 0.0);
        assert_eq!(c, Vec4::new(0.0, 0.0, 1.0, 1.0));
        let c = atlas.sample(i, Vec2::new(0.375, 0.125), 0.0);
        assert_eq!(c, Vec4::new(1.0, 0.0, 0.0, 1.0));
    }

    #[test]
    fn clamped_sampling_stops_at_the_edge_texels() {
        // Red on the left half, blue on the right.
        let img = image::RgbaImage::from_fn(2, 1, |x, _| {
            if x == 0 {
                image::Rgba([255, 0, 0, 255])
            } else {
                image::Rgba([0, 0, 255, 255])
            }
        });
        let mut atlas = TextureAtlas::default();
        let i = atlas.add(&img);
        let red = Vec4::new(1.0, 0.0, 0.0, 1.0);
        let blue = Vec4::new(0.0, 0.0, 1.0, 1.0);
        // Repeating, u = 1.25 is u = 0.25 of the next copy: red; clamped, it is the right edge.
        assert_eq!(atlas.sample(i, Vec2::new(1.25, 0.5), 0.0), red);
        assert_eq!(atlas.sample_with(i, Vec2::new(1.25, 0.5), 0.0, true), blue);
        assert_eq!(atlas.sample_with(i, Vec2::new(-3.0, 0.5), 0.0, true), red);
        // At the edge itself repeating blends with the other side; clamping does not.
        assert_eq!(atlas.sample_with(i, Vec2::new(1.0, 0.5), 0.0, true), blue);
        assert_eq!(atlas.sample(i, Vec2::new(1.0, 0.5), 0.0), (red + blue) * 0.5);
    }

    #[test]
    fn rgb9e5_keeps_high_dynamic_range_within_its_precision() {
        for c in [
            Vec3::new(0.25, 0.5, 1.0),
            Vec3::new(50.0, 20.0, 0.1),
            Vec3::new(1.0 / 255.0, 0.0, 0.0),
            Vec3::splat(65000.0),
            Vec3::new(3.0e-5, 1e-3, 2e-3),
        ] {
            let back = decode_rgb9e5(encode_rgb9e5(c));
            // Each channel within half a mantissa step of the largest channel.
            let step = c.max_element() / 256.0;
            assert!((back - c).abs().max_element() <= step, "{c} -> {back}");
        }
        // Values 8-bit images hold come back to the same 8-bit value.
        for v in 0..=255u8 {
            let back = decode_rgb9e5(encode_rgb9e5(Vec3::splat(v as f32 / 255.0)));
            assert_eq!((back.x * 255.0).round() as u8, v);
        }
        assert_eq!(encode_rgb9e5(Vec3::ZERO), 0);
        assert_eq!(decode_rgb9e5(encode_rgb9e5(Vec3::new(-1.0, f32::NAN, 0.0))), Vec3::ZERO);
        assert_eq!(
            decode_rgb9e5(encode_rgb9e5(Vec3::splat(f32::INFINITY))),
            Vec3::splat(RGB9E5_MAX)
        );
    }

    #[test]
    fn environment_sample_wraps_around_and_clamps_at_the_poles() {
        let img = image::Rgba32FImage::from_fn(4, 2, |x, y| {
            image::Rgba([x as f32 * 10.0, y as f32, 0.0, 1.0])
        });
        let env = EnvironmentMap::from_rgba32f(&img);
        assert_eq!(env.texel(-1, 0), env.texel(3, 0));
        assert_eq!(env.texel(0, 5), env.texel(0, 1));
        assert_eq!(env.texel(3, 0).x, 30.0);
        // Straight up: the top row, bright values kept.
        let up = env.sample(Vec3::Y);
        assert!(up.y.abs() < 1e-6 && up.x > 1.0, "{up}");
    }

    #[test]
    fn equirect_maps_axes() {
        assert!((direction_to_equirect(Vec3::Y).y - 1.0).abs() < 1e-6);
        assert!((direction_to_equirect(Vec3::X) - Vec2::new(0.5, 0.5)).length() < 1e-6);
    }
}

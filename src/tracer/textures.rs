//! Textures for both tracers: every image (diffuse maps and the environment map) packed
//! into one array of RGBA8 texels with a full mip chain per image, addressed by
//! `TextureInfo`. One storage buffer serves any number of textures on any driver; the
//! shader (`shaders/texture.glsl`) and [`TextureAtlas::sample`] filter identically.

use std::path::Path;

use glam::{Vec2, Vec3, Vec4};

/// Where one texture's texels live: offset of level 0, size, mip level count.
pub type TextureInfo = [u32; 4];

/// All textures of a scene, mip-mapped, in one texel array.
#[derive(Clone, Debug, Default)]
pub struct TextureAtlas {
    /// RGBA8 texels, little-endian packed (R in the low byte) as `unpackUnorm4x8` reads them.
    pub texels: Vec<u32>,
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

    fn fetch(&self, info: &TextureInfo, level: u32, x: i32, y: i32) -> Vec4 {
        let [offset, w, h, _] = *info;
        let mut base = offset;
        for k in 0..level {
            let (lw, lh) = level_size(w, h, k);
            base += lw * lh;
        }
        let (lw, lh) = level_size(w, h, level);
        let xi = x.rem_euclid(lw as i32) as u32;
        let yi = y.rem_euclid(lh as i32) as u32;
        unpack(self.texels[(base + yi * lw + xi) as usize])
    }

    fn bilinear(&self, info: &TextureInfo, level: u32, uv: Vec2) -> Vec4 {
        let (lw, lh) = level_size(info[1], info[2], level);
        // v = 0 is the bottom of the image (OBJ convention): flip to rows.
        let p = Vec2::new(uv.x * lw as f32 - 0.5, (1.0 - uv.y) * lh as f32 - 0.5);
        let f = p.floor();
        let t = p - f;
        let (x, y) = (f.x as i32, f.y as i32);
        let a = self.fetch(info, level, x, y).lerp(self.fetch(info, level, x + 1, y), t.x);
        let b = self.fetch(info, level, x, y + 1).lerp(self.fetch(info, level, x + 1, y + 1), t.x);
        a.lerp(b, t.y)
    }

    /// Trilinear sample of texture `index` at `uv` (repeat wrap) and mip level `lod`.
    pub fn sample(&self, index: u32, uv: Vec2, lod: f32) -> Vec4 {
        let info = &self.infos[index as usize];
        let lod = lod.clamp(0.0, (info[3] - 1) as f32);
        let l0 = lod.floor();
        let c0 = self.bilinear(info, l0 as u32, uv);
        if lod > l0 {
            c0.lerp(self.bilinear(info, l0 as u32 + 1, uv), lod - l0)
        } else {
            c0
        }
    }

    /// Texels of texture `index` at level 0 (width * height).
    pub fn texel_count(&self, index: u32) -> u32 {
        let i = &self.infos[index as usize];
        i[1] * i[2]
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

/// Load an equirectangular environment image (PNG, JPEG, HDR, EXR...); high dynamic range
/// values are clamped to [0, 1] since the tracer's output is 8-bit.
pub fn load_environment(path: &Path) -> anyhow::Result<image::RgbaImage> {
    let img = image::open(path).map_err(|e| anyhow::anyhow!("cannot read environment map {}: {e}", path.display()))?;
    Ok(img.to_rgba8())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker(n: u32) -> image::RgbaImage {
        image::RgbaImage::from_fn(n, n, |x, y| if (x + y) % 2 == 0 { image::Rgba([255, 0, 0, 255]) } else { image::Rgba([0, 0, 255, 255]) })
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
    fn equirect_maps_axes() {
        assert!((direction_to_equirect(Vec3::Y).y - 1.0).abs() < 1e-6);
        assert!((direction_to_equirect(Vec3::X) - Vec2::new(0.5, 0.5)).length() < 1e-6);
    }
}

//! A traced image: one RGBA float per pixel (colour or an AOV), plus the 8-bit colour the
//! shader packed. Written as PNG (colour) or 32-bit float OpenEXR (AOVs).

use std::path::Path;

use anyhow::Context;

/// A traced image, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    /// Linear RGBA (colour) or AOV values, `width * height` entries.
    pub pixels: Vec<[f32; 4]>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height, pixels: vec![[0.0; 4]; width as usize * height as usize] }
    }

    /// The pixel at (x, y).
    pub fn get(&self, x: u32, y: u32) -> [f32; 4] {
        self.pixels[(y * self.width + x) as usize]
    }

    /// 8-bit RGBA, clamped and rounded exactly as the shader's `packUnorm4x8`.
    pub(crate) fn to_rgba8(&self) -> image::RgbaImage {
        let bytes = self
            .pixels
            .iter()
            .flat_map(|p| [p[0], p[1], p[2], 1.0].map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8))
            .collect();
        image::RgbaImage::from_raw(self.width, self.height, bytes).expect("size matches")
    }

    /// Write as PNG (8-bit colour) or, for a `.exr` path, 32-bit float RGBA OpenEXR.
    pub(crate) fn save(&self, path: &Path) -> anyhow::Result<()> {
        let is_exr = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
        let result = if is_exr {
            let data = self.pixels.iter().flatten().copied().collect();
            image::Rgba32FImage::from_raw(self.width, self.height, data).expect("size matches").save(path)
        } else {
            self.to_rgba8().save(path)
        };
        result.with_context(|| format!("cannot write {}", path.display()))
    }

    /// Largest per-channel RGB difference and the fraction of pixels whose difference
    /// exceeds `threshold`, for comparing the two tracers.
    pub fn compare(&self, other: &Image, threshold: f32) -> ImageDiff {
        assert_eq!((self.width, self.height), (other.width, other.height), "image sizes differ");
        let mut diff = ImageDiff::default();
        let mut sum = 0.0f64;
        for (a, b) in self.pixels.iter().zip(&other.pixels) {
            let d = (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0f32, f32::max);
            let d = if d.is_nan() { f32::INFINITY } else { d };
            diff.max = diff.max.max(d);
            sum += d as f64;
            if d > threshold {
                diff.over_threshold += 1;
            }
        }
        let n = self.pixels.len().max(1);
        diff.mean = (sum / n as f64) as f32;
        diff.fraction_over = diff.over_threshold as f32 / n as f32;
        diff
    }
}

/// The result of [`Image::compare`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImageDiff {
    pub(crate) max: f32,
    pub mean: f32,
    pub(crate) over_threshold: usize,
    pub fraction_over: f32,
}

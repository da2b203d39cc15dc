//! A traced image: one RGBA float per pixel (colour or an AOV), plus the 8-bit colour the
//! shader packed. Written (through `crate::files`) as PNG (colour, with the settings in a
//! text chunk), JPEG (colour) or 32-bit float OpenEXR (AOVs; depth as one channel `Z`).

use std::path::Path;

use crate::files::image_files::{save_exr_depth, save_exr_rgba, save_jpeg, save_png, OutputFormat};
use crate::render_settings::Aov;

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
            .flat_map(|p| {
                [p[0], p[1], p[2], 1.0].map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8)
            })
            .collect();
        image::RgbaImage::from_raw(self.width, self.height, bytes).expect("size matches")
    }

    /// Write in the format of `path`'s extension ([`OutputFormat`]): PNG (8-bit colour,
    /// with `settings` in its text chunk), JPEG (8-bit RGB) or 32-bit float OpenEXR: RGBA,
    /// except the depth AOV (`aov`), which is one channel named `Z`, as compositors expect.
    pub(crate) fn save(&self, path: &Path, aov: Aov, settings: Option<&str>) -> anyhow::Result<()> {
        match OutputFormat::from_path(path).map_err(anyhow::Error::msg)? {
            OutputFormat::Png => save_png(&self.to_rgba8(), settings, path),
            OutputFormat::Jpeg => save_jpeg(&self.to_rgba8(), path),
            OutputFormat::Exr if aov == Aov::Depth => self.save_depth_exr(path),
            OutputFormat::Exr => save_exr_rgba(self.width, self.height, &self.pixels, path),
        }
    }

    /// The first channel as a single-channel 32-bit float EXR, channel `Z`.
    fn save_depth_exr(&self, path: &Path) -> anyhow::Result<()> {
        save_exr_depth(self.width, self.height, self.pixels.iter().map(|p| p[0]).collect(), path)
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

//! A traced image: one RGBA float per pixel (colour or an AOV), plus the 8-bit colour the
//! shader packed. Written as PNG (colour, with the settings in a text chunk), JPEG (colour)
//! or 32-bit float OpenEXR (AOVs; depth as one channel `Z`).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use anyhow::Context;

use super::frame::Aov;

/// The keyword of the PNG text chunk that holds the settings an image was made with
/// (`SceneSpec::to_preset_text`).
pub(crate) const SETTINGS_KEYWORD: &str = "meshtracer";

/// The file formats `render -o` writes, chosen by the path's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum OutputFormat {
    /// 8-bit RGBA PNG with the settings in a `meshtracer` text chunk.
    Png,
    /// 8-bit RGB JPEG (no alpha).
    Jpeg,
    /// 32-bit float OpenEXR.
    Exr,
}

impl OutputFormat {
    /// The format for `path`'s extension; otherwise one sentence listing the formats.
    pub(crate) fn from_path(path: &Path) -> Result<Self, String> {
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("png") => Ok(OutputFormat::Png),
            Some("jpg" | "jpeg") => Ok(OutputFormat::Jpeg),
            Some("exr") => Ok(OutputFormat::Exr),
            other => {
                let what = other.map_or("no extension".to_string(), |e| format!("'.{e}'"));
                Err(format!("cannot write {}: {what} is not an output format (-o writes .png, .jpg or .jpeg, and .exr for AOVs)", path.display()))
            }
        }
    }
}

/// Encode 8-bit RGBA as PNG, with `settings` (if any) in an iTXt chunk keyworded
/// [`SETTINGS_KEYWORD`].
pub(crate) fn encode_png(rgba: &image::RgbaImage, settings: Option<&str>, out: impl Write) -> Result<(), png::EncodingError> {
    let mut encoder = png::Encoder::new(out, rgba.width(), rgba.height());
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_compression(png::Compression::Fast);
    if let Some(text) = settings {
        encoder.add_itxt_chunk(SETTINGS_KEYWORD.to_string(), text.to_string())?;
    }
    let mut writer = encoder.write_header()?;
    writer.write_image_data(rgba.as_raw())?;
    writer.finish()
}

/// Write 8-bit RGBA as a PNG file carrying `settings` (see [`encode_png`]).
pub(crate) fn save_png(rgba: &image::RgbaImage, settings: Option<&str>, path: &Path) -> anyhow::Result<()> {
    let write = || -> anyhow::Result<()> {
        let mut out = BufWriter::new(File::create(path)?);
        encode_png(rgba, settings, &mut out)?;
        out.flush()?;
        Ok(())
    };
    write().with_context(|| format!("cannot write {}", path.display()))
}

/// Write 8-bit colour as an RGB JPEG (alpha dropped).
pub(crate) fn save_jpeg(rgba: &image::RgbaImage, path: &Path) -> anyhow::Result<()> {
    let write = || -> anyhow::Result<()> {
        let rgb = image::DynamicImage::ImageRgba8(rgba.clone()).into_rgb8();
        let mut out = BufWriter::new(File::create(path)?);
        image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, 95).encode_image(&rgb)?;
        out.flush()?;
        Ok(())
    };
    write().with_context(|| format!("cannot write {}", path.display()))
}

/// The settings text a PNG carries (its `meshtracer` tEXt, zTXt or iTXt chunk); None for a
/// PNG without one. The error is the decoder's, for bytes that are not a PNG.
pub fn png_settings(bytes: &[u8]) -> Result<Option<String>, png::DecodingError> {
    let mut reader = png::Decoder::new(std::io::Cursor::new(bytes)).read_info()?;
    // Text chunks may also follow the image data: read it all.
    let mut buffer = vec![0; reader.output_buffer_size().unwrap_or(0)];
    reader.next_frame(&mut buffer)?;
    reader.finish()?;
    let info = reader.info();
    if let Some(c) = info.utf8_text.iter().find(|c| c.keyword == SETTINGS_KEYWORD) {
        return c.get_text().map(Some);
    }
    if let Some(c) = info.compressed_latin1_text.iter().find(|c| c.keyword == SETTINGS_KEYWORD) {
        return c.get_text().map(Some);
    }
    Ok(info.uncompressed_latin1_text.iter().find(|c| c.keyword == SETTINGS_KEYWORD).map(|c| c.text.clone()))
}

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

    /// Write in the format of `path`'s extension ([`OutputFormat`]): PNG (8-bit colour,
    /// with `settings` in its text chunk), JPEG (8-bit RGB) or 32-bit float OpenEXR: RGBA,
    /// except the depth AOV (`aov`), which is one channel named `Z`, as compositors expect.
    pub(crate) fn save(&self, path: &Path, aov: Aov, settings: Option<&str>) -> anyhow::Result<()> {
        match OutputFormat::from_path(path).map_err(anyhow::Error::msg)? {
            OutputFormat::Png => save_png(&self.to_rgba8(), settings, path),
            OutputFormat::Jpeg => save_jpeg(&self.to_rgba8(), path),
            OutputFormat::Exr if aov == Aov::Depth => self.save_depth_exr(path),
            OutputFormat::Exr => {
                let data = self.pixels.iter().flatten().copied().collect();
                let image = image::Rgba32FImage::from_raw(self.width, self.height, data).expect("size matches");
                image.save(path).with_context(|| format!("cannot write {}", path.display()))
            }
        }
    }

    /// The first channel as a single-channel 32-bit float EXR, channel `Z`.
    fn save_depth_exr(&self, path: &Path) -> anyhow::Result<()> {
        use exr::prelude::*;
        let depth: Vec<f32> = self.pixels.iter().map(|p| p[0]).collect();
        let channels = AnyChannels::sort(SmallVec::from_vec(vec![AnyChannel::new("Z", FlatSamples::F32(depth))]));
        let layer = Layer::new((self.width as usize, self.height as usize), LayerAttributes::default(), Encoding::FAST_LOSSLESS, channels);
        Image::from_layer(layer).write().to_file(path).with_context(|| format!("cannot write {}", path.display()))
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

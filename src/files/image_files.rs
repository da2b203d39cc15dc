//! Image files we write and read back: PNG with the settings in a text chunk, JPEG and
//! 32-bit float OpenEXR (the formats `render -o` chooses by extension), and the settings
//! text a PNG carries (`--preset shot.png`).

use std::io::Write;
use std::path::Path;

use super::write_atomic;
use crate::render_settings::MAX_RESOLUTION;

/// The keyword of the PNG text chunk that holds the settings an image was made with
/// (the scene's preset text).
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
                Err(format!("cannot write {}: {what} is not an output format (-o writes .png, .jpg or .jpeg, and .exr for AOVs)", crate::files::shown_path(path)))
            }
        }
    }
}

/// Encode 8-bit RGBA as PNG, with `settings` (if any) in an iTXt chunk keyworded
/// [`SETTINGS_KEYWORD`].
pub(crate) fn encode_png(
    rgba: &image::RgbaImage,
    settings: Option<&str>,
    out: impl Write,
) -> Result<(), png::EncodingError> {
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
pub(crate) fn save_png(
    rgba: &image::RgbaImage,
    settings: Option<&str>,
    path: &Path,
) -> anyhow::Result<()> {
    write_atomic(path, |out| {
        // The I/O error itself, so `write_atomic` words it ("file too large"): png's error
        // names it only as a `cause`, which anyhow's chain does not follow.
        encode_png(rgba, settings, out).map_err(|e| match e {
            png::EncodingError::IoError(io) => anyhow::Error::from(io),
            e => anyhow::Error::from(e),
        })
    })
}

/// Write 8-bit colour as an RGB JPEG (alpha dropped).
pub(crate) fn save_jpeg(rgba: &image::RgbaImage, path: &Path) -> anyhow::Result<()> {
    let rgb = image::DynamicImage::ImageRgba8(rgba.clone()).into_rgb8();
    write_atomic(path, |out| {
        Ok(image::codecs::jpeg::JpegEncoder::new_with_quality(out, 95).encode_image(&rgb)?)
    })
}

/// Write linear RGBA floats (`width * height`, row 0 at the top) as a 32-bit float
/// OpenEXR. Through the exr crate directly: `image`'s encoder calls a failed write
/// "decoding".
pub(crate) fn save_exr_rgba(
    width: u32,
    height: u32,
    pixels: &[[f32; 4]],
    path: &Path,
) -> anyhow::Result<()> {
    use exr::prelude::*;
    let w = width as usize;
    let channels = SpecificChannels::rgba(|p: Vec2<usize>| {
        let [r, g, b, a] = pixels[p.y() * w + p.x()];
        (r, g, b, a)
    });
    let layer = Layer::new(
        (w, height as usize),
        LayerAttributes::default(),
        Encoding::FAST_LOSSLESS,
        channels,
    );
    write_atomic(path, |out| Ok(Image::from_layer(layer).write().to_buffered(out)?))
}

/// Write one float per pixel as a single-channel 32-bit float OpenEXR, channel `Z` (a
/// depth buffer, as compositors expect it).
pub(crate) fn save_exr_depth(
    width: u32,
    height: u32,
    depth: Vec<f32>,
    path: &Path,
) -> anyhow::Result<()> {
    use exr::prelude::*;
    let channels =
        AnyChannels::sort(SmallVec::from_vec(vec![AnyChannel::new("Z", FlatSamples::F32(depth))]));
    let layer = Layer::new(
        (width as usize, height as usize),
        LayerAttributes::default(),
        Encoding::FAST_LOSSLESS,
        channels,
    );
    write_atomic(path, |out| Ok(Image::from_layer(layer).write().to_buffered(out)?))
}

/// The most settings text read from a PNG, once decompressed (a preset is a few hundred
/// bytes; a compressed chunk can claim gigabytes).
pub(crate) const MAX_SETTINGS_TEXT: usize = 1 << 20;

/// The most memory a PNG read back for its settings may take: the largest image we write
/// (`MAX_RESOLUTION`² RGBA) and room for its chunks. A PNG claiming more is refused
/// before anything of that size is allocated.
const PNG_READ_LIMIT: usize = (MAX_RESOLUTION as usize).pow(2) * 4 + (16 << 20);

/// The settings text a PNG carries (its `meshtracer` tEXt, zTXt or iTXt chunk); None for a
/// PNG without one. The error says why, as words that follow "preset NAME: ": the bytes
/// are not a PNG, the image is bigger than any we write, or the settings text is over
/// [`MAX_SETTINGS_TEXT`].
pub fn png_settings(bytes: &[u8]) -> Result<Option<String>, String> {
    let not_a_png = |e: png::DecodingError| format!("not a readable PNG: {e}");
    let mut reader = png::Decoder::new_with_limits(
        std::io::Cursor::new(bytes),
        png::Limits { bytes: PNG_READ_LIMIT },
    )
    .read_info()
    .map_err(not_a_png)?;
    // Text chunks may also follow the image data: read it all.
    let size = reader
        .output_buffer_size()
        .filter(|&n| n <= PNG_READ_LIMIT)
        .ok_or(png::DecodingError::LimitsExceeded)
        .map_err(not_a_png)?;
    let mut buffer = vec![0; size];
    reader.next_frame(&mut buffer).map_err(not_a_png)?;
    reader.finish().map_err(not_a_png)?;
    let info = reader.info();
    let too_long = || {
        format!(
            "the preset text in the PNG is over the limit of {MAX_SETTINGS_TEXT} bytes (a preset is a page of text)"
        )
    };
    // Decompressed with a bound: `get_text` alone would inflate whatever the chunk claims.
    // png names going past the bound only in its error's Debug text ("Out of decompression
    // space" otherwise); a test holds the two together.
    let decompressed = |e: png::DecodingError| {
        if format!("{e:?}").contains("OutOfDecompressionSpace") {
            too_long()
        } else {
            format!("its preset text cannot be decompressed: {e}")
        }
    };
    let text = if let Some(c) = info.utf8_text.iter().find(|c| c.keyword == SETTINGS_KEYWORD) {
        let mut c = c.clone();
        c.decompress_text_with_limit(MAX_SETTINGS_TEXT).map_err(decompressed)?;
        Some(c.get_text().map_err(decompressed)?)
    } else if let Some(c) =
        info.compressed_latin1_text.iter().find(|c| c.keyword == SETTINGS_KEYWORD)
    {
        let mut c = c.clone();
        c.decompress_text_with_limit(MAX_SETTINGS_TEXT).map_err(decompressed)?;
        Some(c.get_text().map_err(decompressed)?)
    } else {
        let chunks = &info.uncompressed_latin1_text;
        chunks.iter().find(|c| c.keyword == SETTINGS_KEYWORD).map(|c| c.text.clone())
    };
    // An uncompressed chunk has no bound of its own.
    match text {
        Some(text) if text.len() > MAX_SETTINGS_TEXT => Err(too_long()),
        text => Ok(text),
    }
}

//! Fuzz target: arbitrary bytes -> the PNG preset reader (`png_settings`: the settings
//! text chunk of a PNG, bounded in image size and decompressed text) -> the preset reader.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(Some(text)) = meshtracer::files::image_files::png_settings(data) {
        assert!(text.len() <= 1 << 20, "settings text over the 1 MiB bound");
        let _ = meshtracer::scene::preset::from_text(&text);
    }
});

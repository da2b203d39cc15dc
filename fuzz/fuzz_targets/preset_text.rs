//! Fuzz target: arbitrary bytes -> the TOML preset reader (`scene::preset::from_text`) ->
//! the spec's range checks. Nothing a preset holds may panic or allocate without bound.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok((spec, _unknown)) = meshtracer::scene::preset::from_text(text) {
        let _ = spec.validate();
        // What was read writes back as text that reads again.
        let again = meshtracer::scene::preset::from_text(&spec.to_preset_text());
        assert!(again.is_ok(), "a preset written from a read one does not read: {again:?}");
    }
});

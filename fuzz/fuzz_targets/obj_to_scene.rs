//! Fuzz target: arbitrary bytes -> OBJ (+ MTL) loader -> the paper's scene -> packed GPU
//! scene (BVH build) -> BVH validation -> a 4x4 CPU frame. See `../pipeline.rs`.
#![no_main]

use std::path::PathBuf;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;

#[path = "../pipeline.rs"]
mod pipeline;

/// One scratch folder per fuzzing process, for the MTL part of an input.
fn scratch() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("meshtracer-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("cannot create the scratch folder");
        dir
    })
}

fuzz_target!(|data: &[u8]| {
    let _ = pipeline::run(data, scratch());
});

//! Compiles the GLSL compute shaders in `shaders/` to SPIR-V with naga (pure Rust, no
//! external tool). `#include "file"` lines are expanded first, since naga's GLSL front
//! end has no preprocessor includes. The SPIR-V lands in OUT_DIR and is embedded with
//! `include_bytes!`, so the binary can never run a stale shader.
//!
//! The shared constants of `src/tracer/contract.rs` are written out as `contract.glsl`
//! (OUT_DIR) for the shaders to `#include`: a name not found next to the including file is
//! looked up in OUT_DIR.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The shared constants (`ALL`), compiled into the build script too.
#[allow(dead_code)]
mod contract {
    include!("src/tracer/contract.rs");
}

const CONTRACT_SOURCE: &str = "src/tracer/contract.rs";

/// `contract.glsl`: one `const uint` per contract constant, its doc as a comment.
fn contract_glsl() -> String {
    let mut out = format!("// Generated from {CONTRACT_SOURCE} by build.rs: do not edit.\n\n");
    for (name, value, doc) in contract::ALL {
        for line in doc.lines() {
            writeln!(out, "//{line}").unwrap();
        }
        let value = if *value > 0xffff { format!("0x{value:x}u") } else { format!("{value}u") };
        writeln!(out, "const uint {name} = {value};").unwrap();
    }
    out
}

fn expand_includes(path: &Path, out_dir: &Path, depth: u32) -> String {
    assert!(depth < 8, "include nesting too deep at {}", path.display());
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let mut out = String::new();
    for line in text.lines() {
        if let Some(rest) = line.trim_start().strip_prefix("#include") {
            let name = rest.trim().trim_matches('"');
            let beside = path.parent().unwrap().join(name);
            // Generated headers (contract.glsl) live in OUT_DIR, not next to the sources.
            let inc = if beside.exists() { beside } else { out_dir.join(name) };
            out.push_str(&expand_includes(&inc, out_dir, depth + 1));
        } else {
            out.push_str(line);
        }
        out.push('\n');
    }
    out
}

fn compile(src_path: &Path, out_dir: &Path) {
    let src = expand_includes(src_path, out_dir, 0);
    let mut frontend = naga::front::glsl::Frontend::default();
    let options = naga::front::glsl::Options::from(naga::ShaderStage::Compute);
    let module = frontend.parse(&options, &src).unwrap_or_else(|e| {
        panic!("GLSL error in {}:\n{}", src_path.display(), e.emit_to_string(&src));
    });
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .unwrap_or_else(|e| panic!("shader validation failed for {}:\n{}", src_path.display(), e.emit_to_string(&src)));
    let mut spv_options = naga::back::spv::Options::default();
    // Release builds drop debug info; bounds checks stay off (we index with validated data).
    spv_options.flags.remove(naga::back::spv::WriterFlags::DEBUG);
    let spv = naga::back::spv::write_vec(&module, &info, &spv_options, None)
        .unwrap_or_else(|e| panic!("SPIR-V generation failed for {}: {e}", src_path.display()));
    let name = src_path.file_stem().unwrap().to_string_lossy();
    let bytes: Vec<u8> = spv.iter().flat_map(|w| w.to_le_bytes()).collect();
    std::fs::write(out_dir.join(format!("{name}.spv")), bytes).unwrap();
}

fn main() {
    let out_dir = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    println!("cargo:rerun-if-changed={CONTRACT_SOURCE}");
    std::fs::write(out_dir.join("contract.glsl"), contract_glsl()).unwrap();
    println!("cargo:rerun-if-changed=shaders");
    for entry in std::fs::read_dir("shaders").unwrap() {
        let path = entry.unwrap().path();
        println!("cargo:rerun-if-changed={}", path.display());
        if path.extension().is_some_and(|e| e == "comp") {
            compile(&path, &out_dir);
        }
    }
}

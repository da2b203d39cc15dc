use super::*;

#[test]
fn shipped_shaders_compile_at_run_time_to_the_built_in_interface() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let spirv = compile_trace_shader(&dir, Kernel::Ours).unwrap();
    // The same assembly and compiler as build.rs: the very same SPIR-V.
    let bytes: Vec<u8> = spirv.iter().flat_map(|w| w.to_le_bytes()).collect();
    assert!(bytes == TRACE_SPV, "run-time SPIR-V differs from build.rs's");
}

#[test]
fn a_broken_shader_names_its_file_and_line_and_a_changed_interface_is_refused() {
    let src = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let dir = std::env::temp_dir().join(format!("meshtracer-shader-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for file in super::super::shader_compile::shader_files(&src).unwrap() {
        std::fs::copy(&file, dir.join(file.file_name().unwrap())).unwrap();
    }
    let shade = std::fs::read_to_string(dir.join("shade.glsl")).unwrap();
    std::fs::write(dir.join("shade.glsl"), format!("{shade}\nvoid broken( {{\n")).unwrap();
    let e = compile_trace_shader(&dir, Kernel::Ours).unwrap_err();
    let line = shade.lines().count() + 2;
    assert!(e.lines().next().unwrap().contains(&format!("shade.glsl:{line}")), "{e}");
    std::fs::write(dir.join("shade.glsl"), shade).unwrap();
    let scene = std::fs::read_to_string(dir.join("scene.glsl")).unwrap();
    std::fs::write(dir.join("scene.glsl"), scene.replacen("readonly buffer", "buffer", 1)).unwrap();
    let e = compile_trace_shader(&dir, Kernel::Ours).unwrap_err();
    assert!(e.contains("interface"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

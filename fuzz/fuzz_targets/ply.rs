//! Fuzz target: arbitrary bytes -> the PLY reader (`scene::ply::load_ply_from_bytes`), in
//! all three encodings. Nothing a file holds may panic or allocate what the file cannot
//! back (a header's counts are checked against the body first).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(loaded) = meshtracer::scene::ply::load_ply_from_bytes(data, "fuzz.ply") {
        let mesh = loaded.mesh;
        // What loads is a consistent mesh: every index in range, one normal per vertex.
        assert_eq!(mesh.normals.len(), mesh.positions.len());
        assert!(mesh.texcoords.is_empty() || mesh.texcoords.len() == mesh.positions.len());
        assert_eq!(mesh.triangle_materials.len(), mesh.triangles.len());
        assert!(mesh.triangles.iter().flatten().all(|&i| (i as usize) < mesh.positions.len()));
    }
});

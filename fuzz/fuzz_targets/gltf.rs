//! Fuzz target: arbitrary bytes -> the glTF 2.0 reader (`scene::gltf::load_gltf_from_bytes`),
//! as a `.glb` container or as `.gltf` JSON with embedded (data URI) buffers and images.
//! Nothing a file holds may panic, or allocate what its buffers cannot back (accessors,
//! sparse substitutions, buffer views and chunk lengths are checked against the bytes first).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // No folder: external buffers and images cannot be read, so a file naming one is refused
    // (or, for an image, warned about), never looked for on this machine.
    if let Ok(loaded) = meshtracer::scene::gltf::load_gltf_from_bytes(data, "fuzz.glb", None) {
        let model = loaded.model;
        // What loads is a consistent model: parts place meshes it has, with invertible
        // transforms, and every mesh is consistent on its own.
        assert!(!model.parts.is_empty());
        for part in &model.parts {
            assert!(part.mesh < model.meshes.len());
            assert!(part.transform.is_finite());
            assert!(part.transform.matrix3.determinant() != 0.0);
        }
        for mesh in &model.meshes {
            // Every index in range, one normal per vertex, attributes per vertex or none.
            assert_eq!(mesh.normals.len(), mesh.positions.len());
            assert!(mesh.texcoords.is_empty() || mesh.texcoords.len() == mesh.positions.len());
            assert!(mesh.colors.is_empty() || mesh.colors.len() == mesh.positions.len());
            assert_eq!(mesh.triangle_materials.len(), mesh.triangles.len());
            assert!(mesh.triangles.iter().flatten().all(|&i| (i as usize) < mesh.positions.len()));
            assert!(mesh.triangle_materials.iter().all(|&m| (m as usize) < mesh.materials.len()));
            assert!(mesh.positions.iter().all(|p| p.is_finite()));
        }
    }
});

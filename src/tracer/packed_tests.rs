//! Unit tests of `packed.rs`: the GPU structs' layout, packing and the deferred triangles.

use super::*;

#[test]
fn gpu_structs_match_the_shader_layout() {
    assert_eq!(std::mem::size_of::<GpuTriangle>(), 40);
    assert_eq!(std::mem::size_of::<GpuTriangleShading>(), 16);
    assert_eq!(std::mem::size_of::<GpuMaterial>(), 64);
    assert_eq!(std::mem::size_of::<GpuInstance>(), 64);
    assert_eq!(std::mem::size_of::<BvhNode>(), 64);
    assert_eq!(std::mem::size_of::<WideNode>(), 80);
}

#[test]
fn vertex_attributes_are_filled_for_meshes_without_them() {
    // Mesh 0 has neither colours nor texture coordinates, mesh 1 both: the arrays are
    // indexed by global vertex, so mesh 0's vertices read white and (0, 0).
    use crate::scene::paper::{paper_scene, prepare_model, LightOrbit};
    use crate::scene::primitives::PaperModel;
    let mut model = PaperModel::Geosphere.mesh();
    prepare_model(&mut model);
    let mut scene = paper_scene(model, 1, LightOrbit::default());
    let box_mesh = &mut scene.meshes[1];
    box_mesh.colors = vec![[10, 20, 30, 40]; box_mesh.positions.len()];
    box_mesh.texcoords = vec![Vec2::new(0.25, 0.5); box_mesh.positions.len()];
    let packed = PackedScene::new(&scene);
    let v = &packed.vertices;
    let first = scene.meshes[0].vertex_count();
    let total = first + scene.meshes[1].vertex_count();
    assert_eq!((v.normals.len(), v.texcoords.len(), v.colors.len()), (total, total, total));
    assert!(
        v.colors[..first].iter().all(|&c| c == [255; 4])
            && v.colors[first..].iter().all(|&c| c == [10, 20, 30, 40])
    );
    assert!(
        v.texcoords[..first].iter().all(|&t| t == [0.0; 2])
            && v.texcoords[first..].iter().all(|&t| t == [0.25, 0.5])
    );
    // Only the coloured mesh's materials say so; its triangles' corners are its vertices.
    let flags: Vec<bool> = packed.materials.iter().map(GpuMaterial::has_vertex_colors).collect();
    let model_materials = scene.meshes[0].materials.len();
    assert!(
        flags[..model_materials].iter().all(|&f| !f) && flags[model_materials..].iter().all(|&f| f),
        "{flags:?}"
    );
    let m1 = &packed.meshes[1];
    let range = m1.triangle_base as usize..(m1.triangle_base + m1.triangle_count) as usize;
    assert!(packed.shading[range]
        .iter()
        .flat_map(|s| s.corners)
        .all(|k| (first..total).contains(&(k as usize))));
    // Without any, the arrays stay empty (nothing to upload).
    let plain =
        PackedScene::new(&paper_scene(PaperModel::Geosphere.mesh(), 1, LightOrbit::default()));
    assert!(plain.vertices.colors.is_empty() && plain.vertices.texcoords.is_empty());
}

#[test]
fn the_mesh_tables_boxes_give_the_scenes_bounds() {
    // The window takes the world bounds (the ray offset) from the mesh table each frame.
    use crate::scene::paper::{paper_scene, prepare_model, LightOrbit};
    use crate::scene::primitives::PaperModel;
    let mut mesh = PaperModel::TorusKnot.mesh();
    prepare_model(&mut mesh);
    let mut scene = paper_scene(mesh, 3, LightOrbit::default());
    scene.instances[1].translation.x += 7.5;
    let packed = PackedScene::new(&scene);
    let boxes: Vec<_> = packed.meshes.iter().map(|m| m.bounds).collect();
    assert_eq!(scene.bounds_with(&boxes), scene.bounds());
    assert!(scene.bounds().max.x > 7.5, "the moved copy counts");
}

//! Unit tests of `packed.rs`: the GPU structs' layout, packing, the layouts packed, and a
//! load's records (`loaded.rs`) against a full packing's.

use glam::Vec2;

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
    use crate::scene::paper::{paper_scene, prepare_mesh, LightOrbit};
    use crate::scene::primitives::PaperModel;
    let mut model = PaperModel::Geosphere.mesh();
    prepare_mesh(&mut model);
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
    use crate::scene::paper::{paper_scene, prepare_mesh, LightOrbit};
    use crate::scene::primitives::PaperModel;
    let mut mesh = PaperModel::TorusKnot.mesh();
    prepare_mesh(&mut mesh);
    let mut scene = paper_scene(mesh, 3, LightOrbit::default());
    scene.instances[1].transform.translation.x += 7.5;
    let packed = PackedScene::new(&scene);
    let boxes: Vec<_> = packed.meshes.iter().map(|m| m.bounds).collect();
    assert_eq!(scene.bounds_with(&boxes), scene.bounds());
    assert!(scene.bounds().max.x > 7.5, "the moved copy counts");
}

#[test]
fn a_loaded_scene_makes_the_records_a_full_packing_holds() {
    // The upload writes a load's triangles from its scene: the same records, in the same
    // slots, as a packing that holds them, for the model and the mirror box after it.
    use crate::progress::{Phase, Progress};
    use crate::scene::paper::{paper_scene, prepare_mesh, LightOrbit};
    use crate::scene::primitives::PaperModel;
    use crate::tracer::loaded::LoadedScene;
    let mut mesh = PaperModel::TorusKnot.mesh();
    prepare_mesh(&mut mesh);
    mesh.colors = vec![[10, 20, 30, 255]; mesh.positions.len()];
    let scene = paper_scene(mesh, 2, LightOrbit::default());
    let progress = Progress::default();
    for layouts in [Layouts::Binary, Layouts::Both] {
        let full = PackedScene::with_layouts(&scene, layouts);
        let loaded = LoadedScene::pack(scene.clone(), layouts, &progress, DeviceFit::NONE).unwrap();
        assert_eq!(loaded.triangle_count(), full.triangles.len());
        assert_eq!(loaded.buffer_sizes(), full.buffer_sizes());
        for k in 0..full.triangles.len() {
            assert_eq!(loaded.triangle(k), full.triangles[k], "triangle {k}");
            assert_eq!(loaded.shading(k), full.shading[k], "hit record {k}");
        }
        let bits = |t: &TopLevel| {
            let records: &[u32] = bytemuck::cast_slice(&t.instances);
            let nodes: &[u32] = bytemuck::cast_slice(&t.nodes);
            [records, nodes].concat()
        };
        assert_eq!(bits(&loaded.tables().top_level), bits(&full.top_level));
        // What the window keeps rebuilds the instance list as the full packing does.
        let (kept, mut top) = loaded.uploaded();
        let more = crate::scene::paper::instances(500, 3);
        let mut full = full;
        full.set_instances(&more);
        top.set_instances(&more);
        assert_eq!(bits(&top.top_level), bits(&full.top_level));
        assert_eq!(top.has_wide(), full.has_wide());
        assert_eq!(kept.triangle_count(), scene.triangle_count());
    }
    let phases: Vec<Phase> = progress.snapshot().phases.iter().map(|p| p.phase).collect();
    assert_eq!(phases, [Phase::Build, Phase::Pack, Phase::Build, Phase::Pack]);
}

#[test]
fn layouts_hold_what_their_frames_trace() {
    use crate::scene::paper::{paper_scene, prepare_mesh, LightOrbit};
    use crate::scene::primitives::PaperModel;
    let mut mesh = PaperModel::TorusKnot.mesh();
    prepare_mesh(&mut mesh);
    let scene = paper_scene(mesh, 1, LightOrbit::default());
    for (layouts, binary, wide) in
        [(Layouts::Binary, true, false), (Layouts::Wide, false, true), (Layouts::Both, true, true)]
    {
        let packed = PackedScene::with_layouts(&scene, layouts);
        assert_eq!((packed.has_binary(), packed.has_wide()), (binary, wide), "{layouts:?}");
    }
    assert_eq!(Layouts::only(BvhLayout::Wide), Layouts::Wide);
    assert_eq!(Layouts::switchable(BvhLayout::Wide), Layouts::Both);
    assert_eq!(Layouts::switchable(BvhLayout::Binary), Layouts::Binary);
}

#[test]
fn trees_past_the_node_limit_keep_the_wide_trees_alone_then_the_binary_ones() {
    // A device that spans `bytes` and builds no tree itself.
    let within = |bytes| DeviceFit { storage_range: Some(bytes), builds_from: None };
    use crate::render_settings::RenderSettings;
    use crate::scene::paper::{paper_scene, prepare_mesh, LightOrbit};
    use crate::scene::primitives::PaperModel;
    use crate::tracer::FrameParams;
    let mut mesh = PaperModel::TorusKnot.mesh();
    prepare_mesh(&mut mesh);
    let scene = paper_scene(mesh, 1, LightOrbit::default());
    let frame = |bvh| {
        let settings =
            RenderSettings { width: 24, height: 24, bounces: 1, bvh, ..Default::default() };
        FrameParams::new(&scene, settings)
    };
    let binary = PackedScene::with_layouts(&scene, Layouts::Binary);
    let reference = crate::tracer::cpu::render(&binary, &frame(BvhLayout::Binary));
    for layouts in [Layouts::Wide, Layouts::Both] {
        let whole = PackedScene::with_layouts(&scene, layouts);
        // A limit the whole node buffer meets keeps every tree, silently.
        let exact = within(whole.nodes_bytes() as u64);
        let exact = PackedScene::with_layouts_within(&scene, layouts, exact);
        assert!(exact.has_wide() && exact.warnings.is_empty(), "{layouts:?}: {:?}", exact.warnings);
        assert_eq!(exact.nodes_bytes(), whole.nodes_bytes());
        assert_eq!(exact.has_binary(), layouts == Layouts::Both);
        assert!(!exact.some_mesh_lacks_wide());
        let limit = within(whole.nodes_bytes() as u64 - 1);
        let short = PackedScene::with_layouts_within(&scene, layouts, limit);
        assert_eq!(short.warnings.len(), 1, "{:?}", short.warnings);
        assert!(short.warnings[0].starts_with("mirror box: "), "{}", short.warnings[0]);
        if layouts == Layouts::Both {
            // One byte less than both trees: the wide trees alone are kept, as `render`
            // keeps them, and binary frames trace them.
            let wide_alone = PackedScene::with_layouts(&scene, Layouts::Wide);
            assert!(short.has_wide() && !short.has_binary() && !short.some_mesh_lacks_wide());
            assert_eq!(short.nodes_bytes(), wide_alone.nodes_bytes());
            assert_eq!(short.traced_layout(BvhLayout::Binary), BvhLayout::Wide);
            assert!(short.warnings[0].contains("wide BVHs alone"), "{}", short.warnings[0]);
        } else {
            // One byte less than the wide trees: the last (the mirror box's) is not made,
            // the model's still is.
            assert_eq!(short.meshes.iter().map(|m| m.has_wide).collect::<Vec<_>>(), [true, false]);
            assert!(short.some_mesh_lacks_wide());
            assert!(short.warnings[0].contains("its binary BVH"), "{}", short.warnings[0]);
        }
        // No room for any wide tree: every mesh traces its binary tree, wide frames too,
        // and each mesh is named once.
        let none = PackedScene::with_layouts_within(&scene, layouts, within(1));
        assert!(!none.has_wide() && none.has_binary(), "{layouts:?}");
        assert_eq!(none.traced_layout(BvhLayout::Wide), BvhLayout::Binary);
        assert_eq!(none.warnings.len(), scene.meshes.len(), "{:?}", none.warnings);
        assert!(none.warnings[0].contains("storage-buffer range"), "{}", none.warnings[0]);
        for packed in [&short, &none] {
            for bvh in [BvhLayout::Wide, BvhLayout::Binary] {
                let image = crate::tracer::cpu::render(packed, &frame(bvh));
                let over = image.compare(&reference, 1e-4).fraction_over;
                assert!(over <= 0.002, "{layouts:?}, {bvh:?} frames: {over}");
            }
        }
    }
}

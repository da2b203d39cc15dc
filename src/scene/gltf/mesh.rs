//! Placing a glTF scene: the nodes of the default scene with their world matrices, and
//! every triangle primitive they place merged into one mesh in world space.

use std::collections::HashMap;
use std::path::Path;

use ::gltf::accessor::Dimensions;
use ::gltf::{mesh::Mode, Document, Node, Semantic};
use glam::{Mat3, Mat4, Vec2, Vec3};

use super::{convert_material, read_accessor, read_colors, read_indices};
use crate::scene::Mesh;

/// The deepest node hierarchy followed (deeper is taken for a cycle).
const MAX_DEPTH: usize = 64;
/// The most node visits (a node may be the child of many): a bound on instancing blow-up.
const MAX_NODE_VISITS: usize = 1 << 20;

/// The most vertices placed (nodes may instance a mesh many times): 3 GiB of positions.
const MAX_VERTICES: usize = 1 << 28;

/// The nodes of the default scene (else the first, else every root node) with their world matrices.
fn world_nodes<'a>(document: &'a Document) -> Result<Vec<(Node<'a>, Mat4)>, String> {
    let roots: Vec<Node> = match document.default_scene().or_else(|| document.scenes().next()) {
        Some(scene) => scene.nodes().collect(),
        None => {
            let children: std::collections::HashSet<usize> =
                document.nodes().flat_map(|n| n.children().map(|c| c.index())).collect();
            document.nodes().filter(|n| !children.contains(&n.index())).collect()
        }
    };
    let mut out = Vec::new();
    let mut stack: Vec<(Node, Mat4, usize)> =
        roots.into_iter().rev().map(|n| (n, Mat4::IDENTITY, 0)).collect();
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > MAX_DEPTH || out.len() + stack.len() + node.children().len() >= MAX_NODE_VISITS {
            return Err(format!("the node hierarchy is deeper than {MAX_DEPTH} or has more than {MAX_NODE_VISITS} node instances (a cycle?)"));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        stack.extend(
            node.children().collect::<Vec<_>>().into_iter().rev().map(|c| (c, world, depth + 1)),
        );
        out.push((node, world));
    }
    Ok(out)
}

/// Every triangle primitive of the placed nodes, in world space, as one mesh.
pub(super) fn build_mesh(
    document: &Document,
    buffers: &[Vec<u8>],
    name: &str,
    base_dir: Option<&Path>,
    warnings: &mut Vec<String>,
) -> Result<Mesh, String> {
    let mut builder = MeshBuilder::new(buffers, name, base_dir, warnings);
    for (node, world) in world_nodes(document)? {
        let Some(gmesh) = node.mesh() else { continue };
        if !world.is_finite() {
            return Err(format!("node {} has a transform that is not finite", node.index()));
        }
        let place = Placement {
            world,
            normal_matrix: Mat3::from_mat4(world).inverse().transpose(),
            flips: Mat3::from_mat4(world).determinant() < 0.0,
        };
        for prim in gmesh.primitives() {
            if prim.mode() != Mode::Triangles {
                builder.skipped_modes += 1;
                continue;
            }
            let at = format!("mesh {} primitive {}", gmesh.index(), prim.index());
            builder.add_primitive(&prim, &at, &place)?;
        }
    }
    builder.finish()
}

/// A node's world matrix with what follows from it for normals and winding.
struct Placement {
    world: Mat4,
    normal_matrix: Mat3,
    /// A mirroring transform turns the triangles inside out; their corners are swapped back.
    flips: bool,
}

/// The merged mesh as it grows, primitive by primitive. Normals, texture coordinates and
/// colours are kept aside: the mesh gets normals only if every primitive has them, and the
/// others only if any has them (the rest padded).
struct MeshBuilder<'a> {
    buffers: &'a [Vec<u8>],
    name: &'a str,
    base_dir: Option<&'a Path>,
    warnings: &'a mut Vec<String>,
    mesh: Mesh,
    normals: Vec<Vec3>,
    all_normals: bool,
    texcoords: Vec<Vec2>,
    any_texcoords: bool,
    colors: Vec<[u8; 4]>,
    any_colors: bool,
    /// Our material index for each glTF material (`None`: the default material).
    material_slots: HashMap<Option<usize>, u32>,
    skipped_modes: usize,
}

impl<'a> MeshBuilder<'a> {
    fn new(
        buffers: &'a [Vec<u8>],
        name: &'a str,
        base_dir: Option<&'a Path>,
        warnings: &'a mut Vec<String>,
    ) -> Self {
        MeshBuilder {
            buffers,
            name,
            base_dir,
            warnings,
            mesh: Mesh { name: name.to_owned(), ..Default::default() },
            normals: Vec::new(),
            all_normals: true,
            texcoords: Vec::new(),
            any_texcoords: false,
            colors: Vec::new(),
            any_colors: false,
            material_slots: HashMap::new(),
            skipped_modes: 0,
        }
    }

    /// One triangle primitive, placed: its vertices, their attributes, then its triangles.
    fn add_primitive(
        &mut self,
        prim: &::gltf::Primitive,
        at: &str,
        place: &Placement,
    ) -> Result<(), String> {
        let base = self.mesh.positions.len();
        let count = self.add_positions(prim, at, place.world)?;
        self.add_normals(prim, at, place.normal_matrix, count)?;
        self.add_texcoords(prim, at, base, count)?;
        self.add_colors(prim, at, base, count)?;
        self.add_triangles(prim, at, place.flips, base, count)
    }

    /// The primitive's positions in world space; returns how many vertices it has.
    fn add_positions(
        &mut self,
        prim: &::gltf::Primitive,
        at: &str,
        world: Mat4,
    ) -> Result<usize, String> {
        let position = prim.get(&Semantic::Positions).ok_or(format!("{at} has no POSITION"))?;
        let p = read_accessor(&position, self.buffers, "POSITION", Dimensions::Vec3)?;
        let count = p.len() / 3;
        if self.mesh.positions.len() + count > MAX_VERTICES {
            return Err(format!("the scene places more than {MAX_VERTICES} vertices"));
        }
        self.mesh
            .positions
            .extend(p.chunks_exact(3).map(|c| world.transform_point3(Vec3::from_slice(c))));
        Ok(count)
    }

    /// The primitive's normals in world space, while every primitive so far had them.
    fn add_normals(
        &mut self,
        prim: &::gltf::Primitive,
        at: &str,
        normal_matrix: Mat3,
        count: usize,
    ) -> Result<(), String> {
        match prim.get(&Semantic::Normals) {
            Some(acc) if self.all_normals => {
                let n = read_accessor(&acc, self.buffers, "NORMAL", Dimensions::Vec3)?;
                if n.len() != count * 3 {
                    return Err(format!(
                        "{at}: NORMAL has {} elements, POSITION {count}",
                        n.len() / 3
                    ));
                }
                self.normals.extend(
                    n.chunks_exact(3)
                        .map(|c| (normal_matrix * Vec3::from_slice(c)).normalize_or_zero()),
                );
            }
            _ => self.all_normals = false,
        }
        Ok(())
    }

    /// The primitive's TEXCOORD_0, after zeros for earlier vertices without any.
    fn add_texcoords(
        &mut self,
        prim: &::gltf::Primitive,
        at: &str,
        base: usize,
        count: usize,
    ) -> Result<(), String> {
        self.texcoords.resize(base, Vec2::ZERO);
        if let Some(acc) = prim.get(&Semantic::TexCoords(0)) {
            let t = read_accessor(&acc, self.buffers, "TEXCOORD_0", Dimensions::Vec2)?;
            if t.len() / 2 != count {
                return Err(format!(
                    "{at}: TEXCOORD_0 has {} elements, POSITION {count}",
                    t.len() / 2
                ));
            }
            self.texcoords.extend(t.chunks_exact(2).map(Vec2::from_slice));
            self.any_texcoords = true;
        }
        Ok(())
    }

    /// The primitive's COLOR_0, after white for earlier vertices without any.
    fn add_colors(
        &mut self,
        prim: &::gltf::Primitive,
        at: &str,
        base: usize,
        count: usize,
    ) -> Result<(), String> {
        // Primitives without COLOR_0 are white, so they look as they would alone.
        self.colors.resize(base, [255; 4]);
        if let Some(acc) = prim.get(&Semantic::Colors(0)) {
            self.colors.extend(read_colors(&acc, self.buffers, count, at)?);
            self.any_colors = true;
        }
        Ok(())
    }

    /// The primitive's triangles (checked indices) with its material's slot.
    fn add_triangles(
        &mut self,
        prim: &::gltf::Primitive,
        at: &str,
        flips: bool,
        base: usize,
        count: usize,
    ) -> Result<(), String> {
        let indices = match prim.indices() {
            Some(acc) => read_indices(&acc, self.buffers)?,
            None => (0..count as u32).collect(),
        };
        if let Some(&bad) = indices.iter().find(|&&i| i as usize >= count) {
            return Err(format!(
                "{at}: index {bad} is out of range (the primitive has {count} vertices)"
            ));
        }
        let next = self.material_slots.len() as u32;
        let slot = *self.material_slots.entry(prim.material().index()).or_insert_with(|| {
            let material =
                convert_material(&prim.material(), self.base_dir, self.name, self.warnings);
            self.mesh.materials.push(material);
            next
        });
        for t in indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| i + base as u32);
            self.mesh.triangles.push(if flips { [a, c, b] } else { [a, b, c] });
            self.mesh.triangle_materials.push(slot);
        }
        Ok(())
    }

    /// The finished mesh: the checks over all of it, the attributes padded or dropped, and
    /// normals computed where the file's are missing or unusable.
    fn finish(self) -> Result<Mesh, String> {
        let MeshBuilder {
            name,
            warnings,
            mut mesh,
            normals,
            all_normals,
            mut texcoords,
            any_texcoords,
            mut colors,
            any_colors,
            skipped_modes,
            ..
        } = self;
        if skipped_modes > 0 {
            warnings.push(format!("{name}: {skipped_modes} primitives that are not triangles (points, lines, strips or fans) are skipped"));
        }
        if mesh.triangles.is_empty() {
            return Err(
                "the default scene has no triangles, so there is nothing to trace".to_owned()
            );
        }
        if !mesh.positions.iter().all(|p| p.is_finite()) {
            return Err("a vertex position is not a finite number".to_owned());
        }
        if any_texcoords {
            texcoords.resize(mesh.positions.len(), Vec2::ZERO);
            mesh.texcoords = texcoords;
        }
        if any_colors {
            colors.resize(mesh.positions.len(), [255; 4]);
            mesh.colors = colors;
        }
        if all_normals && normals.iter().all(|n| n.is_finite() && *n != Vec3::ZERO) {
            mesh.normals = normals;
            mesh.has_file_normals = true;
        } else {
            mesh.compute_vertex_normals();
        }
        Ok(mesh)
    }
}

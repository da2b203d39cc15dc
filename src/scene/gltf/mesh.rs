//! A glTF scene as a [`Model`]: each glTF mesh the default scene's nodes use becomes one of
//! our meshes, stored once (its triangle primitives merged, each with its material), and
//! each node that has a mesh becomes a part placing it with the node's world transform.

use std::collections::HashMap;
use std::path::Path;

use glam::{Affine2, Affine3A, Mat4, Quat, Vec2, Vec3};
use serde_json::Value as Json;

use super::doc::{array, index_of, numbers, uint, Accessor, Component, Doc, Vertices};
use super::draco;
use super::material::{convert_material, Converted};
use crate::scene::{Camera, Instance, Mesh, Model};

/// The deepest node hierarchy followed (deeper is taken for a cycle).
const MAX_DEPTH: usize = 64;
/// The most node visits (a node may be the child of many): a bound on instancing blow-up.
const MAX_NODE_VISITS: usize = 1 << 20;
/// The most vertices stored over all meshes (each once, however many nodes place it).
const MAX_VERTICES: usize = 1 << 28;

/// glTF's primitive modes we turn into triangles; points and lines (0 to 3) are skipped.
const TRIANGLES: usize = 4;
const TRIANGLE_STRIP: usize = 5;
const TRIANGLE_FAN: usize = 6;

/// The model the default scene (else the first, else every root node) draws.
pub(super) fn build_model(
    doc: &Doc,
    name: &str,
    base_dir: Option<&Path>,
    warnings: &mut Vec<String>,
) -> Result<Model, String> {
    let mut loader = Loader {
        doc,
        name,
        base_dir,
        warnings,
        materials: HashMap::new(),
        vertices: 0,
        skipped_modes: 0,
    };
    let mut model = Model::default();
    // Our mesh for each glTF mesh used so far (None: it has no triangles).
    let mut slots: HashMap<usize, Option<usize>> = HashMap::new();
    let mut flattening = 0;
    let mesh_count = array(doc.root, "meshes").len();
    for (node, index, world) in world_nodes(doc, name, loader.warnings)? {
        if let Some(camera) = node_camera(doc, node, world, name, loader.warnings) {
            model.cameras.push(camera);
        }
        let Some(m) = uint(node, "mesh", &format!("node {index}"))? else { continue };
        if m >= mesh_count {
            return Err(format!(
                "node {index} uses mesh {m}, but the file has {mesh_count} meshes"
            ));
        }
        let slot = match slots.get(&m) {
            Some(&slot) => slot,
            None => {
                let slot = loader.mesh(m)?.map(|mesh| {
                    model.meshes.push(mesh);
                    model.meshes.len() - 1
                });
                slots.insert(m, slot);
                slot
            }
        };
        let Some(slot) = slot else { continue };
        // A node scaled to zero (a hidden part, often animated) places nothing.
        match Instance::new(slot, Affine3A::from_mat4(world)) {
            Ok(part) => model.parts.push(part),
            Err(_) => flattening += 1,
        }
    }
    let Loader { skipped_modes, warnings, .. } = loader;
    if skipped_modes > 0 {
        warnings.push(format!("{name}: {skipped_modes} primitives that are not triangles (points or lines) are skipped"));
    }
    if flattening > 0 {
        warnings.push(format!("{name}: {flattening} nodes whose transform is not finite or flattens their mesh (a scale of zero) are skipped"));
    }
    if model.parts.is_empty() {
        return Err("the default scene has no triangles, so there is nothing to trace".to_owned());
    }
    Ok(model)
}

/// The scene's nodes (depth first, in file order) with their world matrices. A child index
/// the file lacks is skipped with a warning; a hierarchy deeper than [`MAX_DEPTH`] (a cycle)
/// or visited more than [`MAX_NODE_VISITS`] times is refused.
fn world_nodes<'a>(
    doc: &Doc<'a>,
    name: &str,
    warnings: &mut Vec<String>,
) -> Result<Vec<(&'a Json, usize, Mat4)>, String> {
    let nodes = array(doc.root, "nodes");
    let scenes = array(doc.root, "scenes");
    let chosen = uint(doc.root, "scene", "the document")
        .ok()
        .flatten()
        .and_then(|s| scenes.get(s))
        .or(scenes.first());
    let roots: Vec<usize> = match chosen {
        Some(scene) => array(scene, "nodes").iter().filter_map(index_of).collect(),
        None => {
            let children: std::collections::HashSet<usize> = nodes
                .iter()
                .flat_map(|n| array(n, "children").iter().filter_map(index_of))
                .collect();
            (0..nodes.len()).filter(|n| !children.contains(n)).collect()
        }
    };
    let mut missing = 0;
    let mut out = Vec::new();
    let mut stack: Vec<(usize, Mat4, usize)> =
        roots.into_iter().rev().map(|n| (n, Mat4::IDENTITY, 0)).collect();
    while let Some((index, parent, depth)) = stack.pop() {
        let Some(node) = nodes.get(index) else {
            missing += 1;
            continue;
        };
        let children = array(node, "children");
        if depth > MAX_DEPTH || out.len() + stack.len() + children.len() >= MAX_NODE_VISITS {
            return Err(format!("the node hierarchy is deeper than {MAX_DEPTH} or has more than {MAX_NODE_VISITS} node instances (a cycle?)"));
        }
        let world = parent * local_matrix(node);
        stack.extend(children.iter().rev().filter_map(index_of).map(|c| (c, world, depth + 1)));
        out.push((node, index, world));
    }
    if missing > 0 {
        warnings.push(format!(
            "{name}: {missing} references to nodes the file does not have are skipped"
        ));
    }
    Ok(out)
}

/// The perspective camera node `node` carries, placed by its world matrix (glTF cameras
/// look down their local -z, +y up), looking one unit ahead (`prepare_model` moves the
/// target); None without one. An orthographic camera, or one that cannot be placed, is a
/// warning.
fn node_camera(
    doc: &Doc,
    node: &Json,
    world: Mat4,
    name: &str,
    warnings: &mut Vec<String>,
) -> Option<Camera> {
    let index = node.get("camera").and_then(index_of)?;
    let camera = array(doc.root, "cameras").get(index)?;
    let yfov = camera.pointer("/perspective/yfov").and_then(Json::as_f64);
    let yfov = yfov.filter(|y| y.is_finite() && *y > 0.0);
    let Some(yfov) =
        yfov.filter(|_| camera.get("type").and_then(Json::as_str) == Some("perspective"))
    else {
        warnings.push(format!("{name}: camera {index} is not a perspective camera with a field of view, so it is not offered as a viewpoint"));
        return None;
    };
    let position = world.transform_point3(Vec3::ZERO);
    let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
    let up = world.transform_vector3(Vec3::Y).normalize_or_zero();
    if !position.is_finite() || forward == Vec3::ZERO || up == Vec3::ZERO {
        warnings.push(format!(
            "{name}: camera {index} has a transform that cannot place it; it is not offered"
        ));
        return None;
    }
    // Our field of view lies in (1, 179) degrees.
    let vfov_deg = (yfov.to_degrees() as f32).clamp(1.5, 178.5);
    Some(Camera { position, target: position + forward, up, vfov_deg })
}

/// A node's transform relative to its parent: `matrix` (column-major), else translation,
/// rotation (a quaternion, normalized) and scale; what is malformed is left at identity.
fn local_matrix(node: &Json) -> Mat4 {
    if let Some(m) = numbers::<16>(node, "matrix") {
        return Mat4::from_cols_array(&m);
    }
    let t = numbers::<3>(node, "translation").map_or(Vec3::ZERO, Vec3::from);
    let s = numbers::<3>(node, "scale").map_or(Vec3::ONE, Vec3::from);
    let r = numbers::<4>(node, "rotation")
        .map(Quat::from_array)
        .filter(|q| q.length_squared() > 0.0)
        .map_or(Quat::IDENTITY, Quat::normalize);
    Mat4::from_scale_rotation_translation(s, r, t)
}

/// What building the meshes shares: the document, messages, converted materials.
struct Loader<'a, 'w> {
    doc: &'a Doc<'a>,
    name: &'a str,
    base_dir: Option<&'a Path>,
    warnings: &'w mut Vec<String>,
    /// Each glTF material converted once, however many primitives use it.
    materials: HashMap<Option<usize>, Converted>,
    /// Vertices stored so far, over all meshes.
    vertices: usize,
    skipped_modes: usize,
}

impl Loader<'_, '_> {
    /// glTF mesh `m` as one of our meshes: its triangle primitives merged; None when it has
    /// no triangles.
    fn mesh(&mut self, m: usize) -> Result<Option<Mesh>, String> {
        let gmesh = &array(self.doc.root, "meshes")[m];
        let mut builder = MeshBuilder {
            mesh: Mesh { name: self.name.to_owned(), ..Default::default() },
            normals: Vec::new(),
            all_normals: true,
            texcoords: Vec::new(),
            any_texcoords: false,
            colors: Vec::new(),
            any_colors: false,
            slots: HashMap::new(),
        };
        for (p, prim) in array(gmesh, "primitives").iter().enumerate() {
            let at = format!("mesh {m} primitive {p}");
            let mode = uint(prim, "mode", &at)?.unwrap_or(TRIANGLES);
            if !matches!(mode, TRIANGLES | TRIANGLE_STRIP | TRIANGLE_FAN) {
                self.skipped_modes += 1;
                continue;
            }
            self.add_primitive(&mut builder, prim, mode, &at)?;
        }
        builder.finish()
    }

    /// One triangle primitive: its material, vertices and their attributes (from its
    /// accessors, or its Draco data), then triangles.
    fn add_primitive(
        &mut self,
        b: &mut MeshBuilder,
        prim: &Json,
        mode: usize,
        at: &str,
    ) -> Result<(), String> {
        let material = uint(prim, "material", at).ok().flatten();
        if !self.materials.contains_key(&material) {
            let converted =
                convert_material(self.doc, material, self.name, self.base_dir, self.warnings);
            self.materials.insert(material, converted);
        }
        let converted = self.materials[&material].clone();
        let texcoord = format!("TEXCOORD_{}", converted.texcoord);
        let (v, mode) = match prim.pointer("/extensions/KHR_draco_mesh_compression") {
            // Draco decodes to a triangle list, whatever the mode says.
            Some(ext) => (draco::draco_primitive(self.doc, ext, prim, &texcoord, at)?, TRIANGLES),
            None => (self.read_vertices(prim, &texcoord, at)?, mode),
        };
        let count = v.positions.len() / 3;
        if self.vertices + count > MAX_VERTICES {
            return Err(format!("the meshes hold more than {MAX_VERTICES} vertices"));
        }
        self.vertices += count;
        if let Some(&bad) = v.indices.iter().find(|&&i| i as usize >= count) {
            return Err(format!(
                "{at}: index {bad} is out of range (the primitive has {count} vertices)"
            ));
        }
        let base = b.mesh.positions.len();
        b.mesh.positions.extend(v.positions.chunks_exact(3).map(Vec3::from_slice));
        match v.normals {
            Some(n) if b.all_normals => {
                b.normals.extend(n.chunks_exact(3).map(|c| Vec3::from_slice(c).normalize_or_zero()))
            }
            _ => b.all_normals = false,
        }

        // The texture coordinates the material's texture reads, its transform baked in,
        // turned to our convention: glTF's origin is the image's top-left corner, ours
        // (OBJ's) the bottom-left.
        b.texcoords.resize(base, Vec2::ZERO);
        if let Some(t) = v.texcoords {
            let transform = converted.uv_transform.unwrap_or(Affine2::IDENTITY);
            b.texcoords.extend(t.chunks_exact(2).map(|c| {
                let uv = transform.transform_point2(Vec2::from_slice(c));
                Vec2::new(uv.x, 1.0 - uv.y)
            }));
            b.any_texcoords = true;
        }

        // Primitives without COLOR_0 are white, so they look as they would alone.
        b.colors.resize(base, [255; 4]);
        if let Some((values, width)) = v.colors {
            let byte = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
            b.colors.extend(
                values.chunks_exact(width).map(|c| {
                    [byte(c[0]), byte(c[1]), byte(c[2]), c.get(3).map_or(255, |&a| byte(a))]
                }),
            );
            b.any_colors = true;
        }

        let next = b.slots.len() as u32;
        let slot = *b.slots.entry(material).or_insert_with(|| {
            b.mesh.materials.push(converted.material.clone());
            next
        });
        let base = base as u32;
        let corners = triangles(&v.indices, mode);
        b.mesh.triangles.extend(corners.iter().map(|t| t.map(|i| i + base)));
        b.mesh.triangle_materials.extend(std::iter::repeat_n(slot, corners.len()));
        Ok(())
    }

    /// A primitive's vertices from its accessors: POSITION, NORMAL, the `texcoord` its
    /// material reads, COLOR_0, and its indices.
    fn read_vertices(&self, prim: &Json, texcoord: &str, at: &str) -> Result<Vertices, String> {
        let empty = Json::Null;
        let attributes = prim.get("attributes").unwrap_or(&empty);
        let attribute = |key: &str| uint(attributes, key, at);
        let position = attribute("POSITION")?.ok_or(format!("{at} has no POSITION"))?;
        let acc = self.accessor(position, "POSITION", &[3])?;
        // Checked before the read: an accessor without a buffer view is allocated zeros.
        if self.vertices + acc.count > MAX_VERTICES {
            return Err(format!("the meshes hold more than {MAX_VERTICES} vertices"));
        }
        let positions = self.doc.read(&acc, "POSITION", |v| v as f32)?;
        let count = acc.count;
        let per_vertex = |acc, what: &str| per_vertex(acc, what, at, count);
        let normals = match attribute("NORMAL")? {
            Some(n) => {
                let acc = per_vertex(self.accessor(n, "NORMAL", &[3])?, "NORMAL")?;
                Some(self.doc.read(&acc, "NORMAL", |v| v as f32)?)
            }
            None => None,
        };
        let texcoords = match attribute(texcoord)? {
            Some(t) => {
                let acc = per_vertex(self.accessor(t, texcoord, &[2])?, texcoord)?;
                Some(self.doc.read(&acc, texcoord, |v| v as f32)?)
            }
            None => None,
        };
        let colors = match attribute("COLOR_0")? {
            Some(c) => Some(self.colors(c, at, count)?),
            None => None,
        };
        let indices = self.indices(prim, at, count)?;
        Ok(Vertices { positions, normals, texcoords, colors, indices })
    }

    /// A primitive's `COLOR_0` (RGB or RGBA; float, or normalized unsigned byte or short, as
    /// glTF allows) in [0, 1], and its width; `count` is its vertex count.
    fn colors(&self, c: usize, at: &str, count: usize) -> Result<(Vec<f32>, usize), String> {
        let acc = per_vertex(self.accessor(c, "COLOR_0", &[3, 4])?, "COLOR_0", at, count)?;
        if !(acc.component == Component::F32
            || (acc.normalized && matches!(acc.component, Component::U8 | Component::U16)))
        {
            return Err(format!("accessor {c} (COLOR_0) has component type {:?}; glTF allows float or normalized unsigned byte or short", acc.component));
        }
        Ok((self.doc.read(&acc, "COLOR_0", |v| v as f32)?, acc.width))
    }

    /// A primitive's vertex indices (checked against its vertex count by the caller), or
    /// its `count` vertices in order when it has none.
    fn indices(&self, prim: &Json, at: &str, count: usize) -> Result<Vec<u32>, String> {
        let indices = match uint(prim, "indices", at)? {
            Some(i) => {
                let acc = self.accessor(i, "indices", &[1])?;
                if !acc.component.is_unsigned_integer() {
                    return Err(format!(
                        "accessor {i} (indices) has component type {:?}, not an unsigned integer",
                        acc.component
                    ));
                }
                self.doc.read(&acc, "indices", |v| v as u32)?
            }
            None => (0..count as u32).collect(),
        };
        Ok(indices)
    }

    /// Accessor `index`, checked to have one of `widths` components per element.
    fn accessor(&self, index: usize, what: &str, widths: &[usize]) -> Result<Accessor, String> {
        let acc = self.doc.accessor(index, what)?;
        if !widths.contains(&acc.width) {
            let expected: Vec<String> = widths
                .iter()
                .map(|w| if *w == 1 { "SCALAR".into() } else { format!("VEC{w}") })
                .collect();
            let kind = if acc.width == 1 { "SCALAR".into() } else { format!("VEC{}", acc.width) };
            return Err(format!(
                "accessor {index} ({what}) is of type {kind}, expected {}",
                expected.join(" or ")
            ));
        }
        Ok(acc)
    }
}

/// `acc`, checked to have one element per vertex before it is read: a count the file
/// cannot back (no buffer view) is never allocated.
fn per_vertex(acc: Accessor, what: &str, at: &str, count: usize) -> Result<Accessor, String> {
    if acc.count == count {
        Ok(acc)
    } else {
        Err(format!("{at}: {what} has {} elements, POSITION {count}", acc.count))
    }
}

/// The triangles of a list, strip or fan of vertex `indices` (glTF's orders, which keep
/// every triangle's winding).
fn triangles(indices: &[u32], mode: usize) -> Vec<[u32; 3]> {
    let n = indices.len();
    match mode {
        TRIANGLE_STRIP => (0..n.saturating_sub(2))
            .map(|i| {
                let odd = i % 2;
                [indices[i], indices[i + 1 + odd], indices[i + 2 - odd]]
            })
            .collect(),
        TRIANGLE_FAN => {
            (1..n.saturating_sub(1)).map(|i| [indices[i], indices[i + 1], indices[0]]).collect()
        }
        _ => indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
    }
}

/// One mesh as it grows, primitive by primitive. Normals, texture coordinates and colours
/// are kept aside: the mesh gets normals only if every primitive has them, and the others
/// if any has them (the rest padded).
struct MeshBuilder {
    mesh: Mesh,
    normals: Vec<Vec3>,
    all_normals: bool,
    texcoords: Vec<Vec2>,
    any_texcoords: bool,
    colors: Vec<[u8; 4]>,
    any_colors: bool,
    /// Our material index in this mesh for each glTF material (`None`: the default).
    slots: HashMap<Option<usize>, u32>,
}

impl MeshBuilder {
    /// The finished mesh (None without triangles): the checks over all of it, the
    /// attributes padded or dropped, and normals computed where the file's are missing or
    /// unusable.
    fn finish(self) -> Result<Option<Mesh>, String> {
        let MeshBuilder {
            mut mesh,
            normals,
            all_normals,
            mut texcoords,
            any_texcoords,
            mut colors,
            any_colors,
            ..
        } = self;
        if mesh.triangles.is_empty() {
            return Ok(None);
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
        Ok(Some(mesh))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_keep_their_winding() {
        assert_eq!(triangles(&[0, 1, 2, 3], TRIANGLE_STRIP), [[0, 1, 2], [1, 3, 2]]);
        assert_eq!(triangles(&[0, 1, 2, 3], TRIANGLE_FAN), [[1, 2, 0], [2, 3, 0]]);
        assert_eq!(triangles(&[0, 1], TRIANGLE_STRIP), Vec::<[u32; 3]>::new());
        assert_eq!(triangles(&[5, 6, 7, 8], TRIANGLES), [[5, 6, 7]]);
    }
}

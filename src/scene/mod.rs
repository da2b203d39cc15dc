//! What is traced: meshes (from OBJ, PLY or glTF files or the paper's generators, loaded
//! through [`formats::load_model`]), their materials, instances of them placed in the world,
//! the camera and the light.

pub mod camera;
mod decimal;
pub mod formats;
pub mod gltf;
mod normals;
pub mod obj;
pub mod paper;
pub mod ply;
pub mod preset;
pub mod primitives;
pub mod spec;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{Affine3A, Vec2, Vec3};
use rayon::prelude::*;

use crate::geometry::Aabb;

pub use camera::Camera;

/// A Blinn–Phong material (the paper's diffuse and specular terms) plus how strongly the
/// surface mirrors: the reflection blend ratio is scaled by `mirror`.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Diffuse reflectance (`Kd`).
    pub diffuse: Vec3,
    /// Specular reflectance (`Ks`).
    pub specular: Vec3,
    /// Blinn–Phong exponent (`Ns`).
    pub shininess: f32,
    /// 0 = matte, 1 = takes part fully in the mirror blend.
    pub mirror: f32,
    /// The diffuse texture: `map_Kd` when the .mtl names one (resolved relative to the
    /// .mtl), a glTF base colour texture (a file beside it, or bytes inside it).
    pub diffuse_texture: Option<TextureSource>,
    /// How `diffuse_texture` is laid on the surface (`map_Kd`'s `-o`, `-s`, `-clamp`).
    pub texture_transform: TextureTransform,
}

/// How a texture is laid on the surface, from the `-s`, `-o` and `-clamp` options of a
/// `map_Kd` statement: texture coordinates become `uv * scale + offset` before the lookup,
/// and then repeat (the default) or, with `clamp`, stop at the texture's edges. Both
/// tracers apply it the same way (`shaders/texture.glsl`, `TextureAtlas::sample_with`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureTransform {
    /// `-s u v`: scale of the texture coordinates (1, 1 by default).
    pub scale: Vec2,
    /// `-o u v`: offset added after the scale (0, 0 by default).
    pub offset: Vec2,
    /// `-clamp on`: coordinates outside [0, 1] take the edge texels instead of repeating.
    pub clamp: bool,
}

/// Where a texture's image comes from: a file on disk (OBJ's `map_Kd`, a glTF's external
/// image), or encoded bytes the model file holds (a glTF buffer view or `data:` URI), decoded
/// with the other textures when the scene is prepared.
#[derive(Clone, PartialEq, Eq, Hash)]
pub enum TextureSource {
    /// An image file, read when the scene is prepared.
    File(PathBuf),
    /// An encoded image (PNG, JPEG...) held in memory; `name` says where it came from.
    Embedded { name: String, bytes: Arc<[u8]> },
}

impl TextureSource {
    /// The file, when the texture is one.
    pub fn path(&self) -> Option<&Path> {
        match self {
            TextureSource::File(p) => Some(p),
            TextureSource::Embedded { .. } => None,
        }
    }
}

impl std::fmt::Debug for TextureSource {
    /// The path, or the name and size: an embedded image's bytes are not worth printing.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TextureSource::File(p) => f.debug_tuple("File").field(p).finish(),
            TextureSource::Embedded { name, bytes } => {
                write!(f, "Embedded({name:?}, {} bytes)", bytes.len())
            }
        }
    }
}

impl Default for TextureTransform {
    fn default() -> Self {
        Self { scale: Vec2::ONE, offset: Vec2::ZERO, clamp: false }
    }
}

impl TextureTransform {
    /// The texture coordinates a lookup uses for the surface's `uv` (before wrap or clamp).
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        uv * self.scale + self.offset
    }
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: "default".into(),
            diffuse: Vec3::splat(0.8),
            specular: Vec3::splat(0.5),
            shininess: 32.0,
            mirror: 1.0,
            diffuse_texture: None,
            texture_transform: TextureTransform::default(),
        }
    }
}

/// An indexed triangle mesh. Vertex attributes share one index (tobj's `single_index`).
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Where the mesh came from ("geosphere", a file path, ...), for messages.
    pub name: String,
    pub positions: Vec<Vec3>,
    /// Per-vertex normals, same length as `positions`: from the file's `vn`, or
    /// area-weighted averages of the face normals when the file has none.
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates, same length as `positions`, or empty.
    pub texcoords: Vec<Vec2>,
    /// Per-vertex colours (RGBA8, as stored in the file: no colour-space conversion, like
    /// texture texels), same length as `positions`, or empty. The diffuse colour is
    /// multiplied by them (glTF's `COLOR_0` rule; PLY scans give `red green blue`).
    pub colors: Vec<[u8; 4]>,
    /// Triangles in file order (a quad's two triangles follow each other).
    pub triangles: Vec<[u32; 3]>,
    /// Material index of each triangle (into `materials`).
    pub triangle_materials: Vec<u32>,
    /// At least one material.
    pub materials: Vec<Material>,
    /// True when the normals came from the file.
    pub has_file_normals: bool,
}

impl Mesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// The three corner positions of triangle `i`.
    pub fn corners(&self, i: usize) -> [Vec3; 3] {
        self.triangles[i].map(|k| self.positions[k as usize])
    }

    /// Bounding box of all vertices.
    pub fn bounds(&self) -> Aabb {
        // Fixed-size pieces folded in order: the same box (signed zeros included, which
        // `min`/`max` may pick either of) on any thread count.
        let pieces: Vec<Aabb> = self.positions.par_chunks(1 << 16).map(piece_bounds).collect();
        pieces.into_iter().fold(Aabb::EMPTY, Aabb::union)
    }

    /// Area-weighted vertex normals from the triangles (used when a file has no `vn`), on
    /// every core with the same bits on any thread count (see `normals.rs`).
    pub fn compute_vertex_normals(&mut self) {
        self.normals = normals::area_weighted_normals(&self.positions, &self.triangles);
        self.has_file_normals = false;
    }

    /// Uniformly scale and translate the mesh so that its bounding box is centred at the
    /// origin and its largest half-extent is `radius` (models of any size fit the scene).
    pub fn normalize_to(&mut self, radius: f32) {
        let b = self.bounds();
        if b.is_empty() {
            return;
        }
        // In f64: extents near f32::MAX overflow and subnormal ones underflow in f32.
        let (min, max) = (b.min.as_dvec3(), b.max.as_dvec3());
        let c = (min + max) * 0.5;
        let half = (max - min).max_element() * 0.5;
        let s = if half > 0.0 { radius as f64 / half } else { 1.0 };
        self.positions.par_iter_mut().for_each(|p| *p = ((p.as_dvec3() - c) * s).as_vec3());
    }
}

/// The box of `points`, kept in four running boxes: one box is a chain of dependent
/// min/max operations, which ran at a third of the speed.
fn piece_bounds(points: &[Vec3]) -> Aabb {
    let mut boxes = [Aabb::EMPTY; 4];
    let mut quads = points.chunks_exact(4);
    for q in &mut quads {
        for (b, &p) in boxes.iter_mut().zip(q) {
            *b = b.grow_point(p);
        }
    }
    for &p in quads.remainder() {
        boxes[0] = boxes[0].grow_point(p);
    }
    boxes.into_iter().fold(Aabb::EMPTY, Aabb::union)
}

/// A placement of a mesh in the world: any invertible affine transform (rotation,
/// non-uniform or mirrored scale, translation), object to world. The tracers carry rays
/// into the mesh's space with the inverse and normals out with its transpose, so ray
/// parameters stay world distances and a mirrored instance keeps its outward side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    /// Index into `Scene::meshes`.
    pub mesh: usize,
    /// Object space to world space.
    pub transform: Affine3A,
}

/// Smallest |determinant| a transform may have relative to the cube of its largest
/// column: below it the inverse loses most of its digits and rays miss the mesh at random.
const MIN_RELATIVE_DETERMINANT: f32 = 1e-6;

impl Instance {
    /// `mesh` placed by `transform`; a transform that is not finite or flattens space (a zero
    /// or nearly zero scale) is refused with one sentence.
    pub fn new(mesh: usize, transform: Affine3A) -> Result<Self, String> {
        let m = transform.matrix3;
        let finite = m.is_finite() && transform.translation.is_finite();
        let largest =
            [m.x_axis, m.y_axis, m.z_axis].map(|c| c.length()).into_iter().fold(0.0, f32::max);
        if !finite {
            return Err(format!("the transform of an instance of mesh {mesh} is not finite"));
        }
        if largest == 0.0 || m.determinant().abs() <= MIN_RELATIVE_DETERMINANT * largest.powi(3) {
            return Err(format!(
                "the transform of an instance of mesh {mesh} is singular (it flattens the mesh: \
                 a scale of zero or axes that coincide)"
            ));
        }
        Ok(Self { mesh, transform })
    }

    /// `mesh` scaled uniformly by `scale`, then moved by `translation` (the paper's copies).
    pub fn placed(mesh: usize, translation: Vec3, scale: f32) -> Self {
        Self {
            mesh,
            transform: Affine3A::from_scale_rotation_translation(
                Vec3::splat(scale),
                glam::Quat::IDENTITY,
                translation,
            ),
        }
    }

    /// The world box of `bounds` (the mesh's box) under the transform: its eight corners'.
    pub fn world_bounds(&self, bounds: Aabb) -> Aabb {
        if bounds.is_empty() {
            return bounds;
        }
        (0..8).fold(Aabb::EMPTY, |acc, i| {
            let corner = Vec3::new(
                if i & 1 == 0 { bounds.min.x } else { bounds.max.x },
                if i & 2 == 0 { bounds.min.y } else { bounds.max.y },
                if i & 4 == 0 { bounds.min.z } else { bounds.max.z },
            );
            acc.grow_point(self.transform.transform_point3(corner))
        })
    }
}

/// A model as loaded: its meshes and the parts that place them in the model's own frame
/// (one part at the identity for an OBJ or PLY file or a generated model; a glTF file's
/// nodes). A scene places the whole model once per copy.
#[derive(Clone, Debug, Default)]
pub struct Model {
    pub meshes: Vec<Mesh>,
    /// Placements in the model's frame; each `mesh` indexes `meshes`.
    pub parts: Vec<Instance>,
    /// Viewpoints the file defines (a glTF file's cameras), in the model's frame: fitted
    /// with it by `paper::prepare_model`, offered by `SceneSpec::file_camera`.
    pub cameras: Vec<Camera>,
}

impl From<Mesh> for Model {
    fn from(mesh: Mesh) -> Self {
        Model {
            meshes: vec![mesh],
            parts: vec![Instance::placed(0, Vec3::ZERO, 1.0)],
            cameras: Vec::new(),
        }
    }
}

impl Model {
    /// True when the model is one mesh placed as it is (what OBJ and PLY files give).
    pub fn is_single_mesh(&self) -> bool {
        self.meshes.len() == 1
            && self.parts.len() == 1
            && self.parts[0].transform == Affine3A::IDENTITY
    }

    /// Triangles of the model as placed, counting each part.
    pub fn triangle_count(&self) -> usize {
        self.parts.iter().map(|p| self.meshes[p.mesh].triangle_count()).sum()
    }

    /// The model's box in its own frame: its parts' boxes.
    pub fn bounds(&self) -> Aabb {
        let mesh_bounds: Vec<Aabb> = self.meshes.iter().map(Mesh::bounds).collect();
        self.parts.iter().fold(Aabb::EMPTY, |acc, p| acc.union(p.world_bounds(mesh_bounds[p.mesh])))
    }

    /// The model as one mesh, every part's triangles moved to where the part puts them
    /// (materials appended per mesh): a reference for tests, and for callers that want
    /// a single mesh.
    pub fn flatten(&self) -> Mesh {
        if self.is_single_mesh() {
            return self.meshes[0].clone();
        }
        let mut out = Mesh {
            name: self.meshes.first().map_or_else(String::new, |m| m.name.clone()),
            ..Default::default()
        };
        let mut material_base = Vec::with_capacity(self.meshes.len());
        for m in &self.meshes {
            material_base.push(out.materials.len() as u32);
            out.materials.extend(m.materials.iter().cloned());
        }
        let keep_texcoords = self.parts.iter().all(|p| !self.meshes[p.mesh].texcoords.is_empty());
        let keep_colors = self.parts.iter().any(|p| !self.meshes[p.mesh].colors.is_empty());
        out.has_file_normals = self.parts.iter().all(|p| self.meshes[p.mesh].has_file_normals);
        for part in &self.parts {
            let m = &self.meshes[part.mesh];
            let base = out.positions.len() as u32;
            let normal_matrix = part.transform.matrix3.inverse().transpose();
            out.positions.extend(m.positions.iter().map(|&p| part.transform.transform_point3(p)));
            out.normals.extend(m.normals.iter().map(|&n| (normal_matrix * n).normalize_or_zero()));
            if keep_texcoords {
                out.texcoords.extend_from_slice(&m.texcoords);
            }
            if keep_colors {
                if m.colors.is_empty() {
                    out.colors.extend(std::iter::repeat_n([255; 4], m.positions.len()));
                } else {
                    out.colors.extend_from_slice(&m.colors);
                }
            }
            // A mirroring part turns its triangles' winding around; keep them facing out.
            let flip = part.transform.matrix3.determinant() < 0.0;
            out.triangles.extend(m.triangles.iter().map(|t| {
                let t = t.map(|k| k + base);
                if flip {
                    [t[0], t[2], t[1]]
                } else {
                    t
                }
            }));
            out.triangle_materials
                .extend(m.triangle_materials.iter().map(|&k| k + material_base[part.mesh]));
        }
        if out.materials.is_empty() {
            out.materials.push(Material::default());
        }
        out
    }
}

/// How a scene was put together from its spec (the model's parts, the mirror box, the
/// other objects), kept with it so the copies can be placed again without loading
/// anything: the window's copy count, scatter and mirror-box controls.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Assembly {
    /// The model's parts, with `mesh` indexing `Scene::meshes`: placed once per copy.
    pub model_parts: Vec<Instance>,
    /// The paper's mirror box's mesh, when the scene has one.
    pub mirror_box: Option<usize>,
    /// The other objects' instances, already in world space.
    pub objects: Vec<Instance>,
}

/// A point light (the paper's orbiting light).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointLight {
    pub position: Vec3,
    pub color: Vec3,
}

/// What rays that hit nothing see, besides the plain background colour.
#[derive(Clone, Debug, PartialEq)]
pub enum EnvironmentSource {
    /// The sky gradient generated in code (works with no file).
    Sky,
    /// An equirectangular image (PNG, JPEG, HDR, EXR...).
    File(PathBuf),
}

impl EnvironmentSource {
    /// Parse `--env`: `none` (None), `sky`, or a path.
    pub(crate) fn parse(s: &str) -> Option<Self> {
        match s.to_ascii_lowercase().as_str() {
            "none" | "black" | "off" => None,
            "sky" => Some(EnvironmentSource::Sky),
            _ => Some(EnvironmentSource::File(PathBuf::from(s))),
        }
    }
}

/// Everything the tracers need: meshes, instances, camera, light and background.
#[derive(Clone, Debug)]
pub struct Scene {
    pub meshes: Vec<Mesh>,
    pub instances: Vec<Instance>,
    pub camera: Camera,
    pub light: PointLight,
    /// Colour of rays that hit nothing (the paper: black).
    pub background: Vec3,
    /// Ambient fraction of the diffuse colour, so unlit sides are not pitch black.
    pub ambient: f32,
    /// Environment map seen by misses (None: the background colour, the paper's black).
    pub environment: Option<EnvironmentSource>,
    /// What the instances were made from (empty for a scene written out by hand).
    pub assembly: Assembly,
}

impl Scene {
    /// Triangles in the world, counting each instance.
    pub fn triangle_count(&self) -> usize {
        self.instances.iter().map(|i| self.meshes[i.mesh].triangle_count()).sum()
    }

    /// Vertices in the world, counting each instance.
    pub(crate) fn vertex_count(&self) -> usize {
        self.instances.iter().map(|i| self.meshes[i.mesh].vertex_count()).sum()
    }

    /// The scene without the paper's mirror box: only the model instances stay, so an
    /// environment map is seen around the models and in their reflections.
    pub(crate) fn without_box(mut self) -> Self {
        self.remove_box();
        self
    }

    /// Take the paper's mirror box out of the instance list (see [`Scene::without_box`]).
    pub(crate) fn remove_box(&mut self) {
        let mirror_box = self.assembly.mirror_box;
        self.instances.retain(|i| Some(i.mesh) != mirror_box);
    }

    /// Place `count` copies of the model again, turned by `scatter`'s seed, with or
    /// without the mirror box, and the other objects where they were: the instance list
    /// a spec with these values gives, without loading anything.
    pub fn place_copies(&mut self, count: u32, scatter: u32, mirror_box: bool) {
        self.instances = paper::place(&self.assembly, count, scatter, mirror_box);
    }

    /// World-space bounding box of all instances.
    pub(crate) fn bounds(&self) -> Aabb {
        self.bounds_of(self.instances.iter())
    }

    /// World-space bounding box of everything but the mirror box: what "frame the
    /// model" looks at.
    pub(crate) fn model_bounds(&self) -> Aabb {
        let mirror_box = self.assembly.mirror_box;
        self.bounds_of(self.instances.iter().filter(|i| Some(i.mesh) != mirror_box))
    }

    /// [`Self::bounds`] from each mesh's own box, `mesh_bounds[i]` for `meshes[i]`: a
    /// caller that keeps them (the packed scene's mesh table) skips a pass over every
    /// vertex, which the window would otherwise pay each frame (~3 ms at 10M triangles).
    pub(crate) fn bounds_with(&self, mesh_bounds: &[Aabb]) -> Aabb {
        self.bounds_by(self.instances.iter(), |mesh| mesh_bounds[mesh])
    }

    fn bounds_of<'a>(&'a self, instances: impl Iterator<Item = &'a Instance>) -> Aabb {
        self.bounds_by(instances, |mesh| self.meshes[mesh].bounds())
    }

    fn bounds_by<'a>(
        &'a self,
        instances: impl Iterator<Item = &'a Instance>,
        mesh_bounds: impl Fn(usize) -> Aabb,
    ) -> Aabb {
        instances
            .fold(Aabb::EMPTY, |acc, inst| acc.union(inst.world_bounds(mesh_bounds(inst.mesh))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_in_pieces_equal_the_box_of_all_points() {
        // Several pieces, and a length that is not a multiple of four.
        let positions: Vec<Vec3> = (0..200_003u64)
            .map(|i| {
                Vec3::new(
                    (i * 7919 % 1000) as f32,
                    -((i * 104_729 % 777) as f32),
                    (i % 13) as f32 * 0.5,
                )
            })
            .collect();
        let mesh = Mesh { positions, ..Default::default() };
        assert_eq!(mesh.bounds(), Aabb::from_points(&mesh.positions));
        assert!(Mesh::default().bounds().is_empty());
    }
}

//! The records the GPU reads, laid out byte for byte as `shaders/scene.glsl` reads them
//! (and the CPU reference reads them the same way): a triangle for the traversal and its
//! hit record for the shading, the vertex attributes the hit records index, materials and
//! placed meshes; and how a mesh's triangle becomes its two records. `packed.rs` fills
//! arrays of them.

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::scene::{Material, Mesh};

/// A triangle as the traversal reads it (40 bytes: `shaders/scene.glsl`'s
/// `load_triangle` reads it as five 8-byte words). The material is in
/// [`GpuTriangleShading`], read only at a hit. 40 bytes rather than 48 took 5-7% off the
/// 4M and 10M knots' frames on the H100 and put nodes and triangles under the driver's
/// structure (76.7 against 79.8 bytes a triangle); 36 (nine single floats) was as fast on
/// the big meshes but up to 10% slower on Sponza: its nine 4-byte loads against five
/// 8-byte ones (docs/BENCHMARKS.md).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangle {
    pub v0: [f32; 3],
    pub e1: [f32; 3],
    pub e2: [f32; 3],
    /// Index of the triangle in its mesh's file order (the prim-id view).
    pub prim: u32,
}

// The size statistics count triangle bytes as the traversal reads them.
const _: () =
    assert!(std::mem::size_of::<GpuTriangle>() == crate::bvh::wide::stats::TRIANGLE_BYTES);

/// What the shading reads at a triangle's hit (16 bytes, one `uvec4`): its corners'
/// indices into [`PackedVertices`] and its global material index.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangleShading {
    pub corners: [u32; 3],
    pub material: u32,
}

impl GpuTriangle {
    /// Corner 0 and the two edges, as used by Möller–Trumbore.
    pub(crate) fn edges(&self) -> [Vec3; 3] {
        [Vec3::from(self.v0), Vec3::from(self.e1), Vec3::from(self.e2)]
    }
}

/// The vertex attributes the shading reads at a hit, shared by the triangles that meet at
/// a vertex (`GpuTriangleShading::corners` index them): 12 to 24 bytes a vertex, where a
/// 64-byte record of three corners a triangle used to be. Arrays a scene does not use stay
/// empty (no mesh with texture coordinates, none with colours).
#[derive(Clone, Debug, Default)]
pub struct PackedVertices {
    /// Vertex normals (object space), every vertex of every mesh.
    pub normals: Vec<[f32; 3]>,
    /// Texture coordinates per vertex, or empty when no mesh has any (zero where a mesh
    /// lacks them).
    pub texcoords: Vec<[f32; 2]>,
    /// RGBA8 colours per vertex, or empty when no mesh has any (white where a mesh lacks
    /// them).
    pub colors: Vec<[u8; 4]>,
}

impl PackedVertices {
    /// The normals of `corners`.
    pub(crate) fn normals_of(&self, corners: [u32; 3]) -> [Vec3; 3] {
        corners.map(|k| Vec3::from(self.normals[k as usize]))
    }

    /// The texture coordinates of `corners` (zero without any).
    pub(crate) fn texcoords_of(&self, corners: [u32; 3]) -> [Vec2; 3] {
        corners.map(|k| self.texcoords.get(k as usize).map_or(Vec2::ZERO, |&t| Vec2::from(t)))
    }

    /// The colours of `corners`, in [0, 1] (white without any).
    pub(crate) fn colors_of(&self, corners: [u32; 3]) -> [Vec3; 3] {
        corners.map(|k| {
            self.colors
                .get(k as usize)
                .map_or(Vec3::ONE, |c| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) / 255.0)
        })
    }

    /// Append `mesh`'s vertices; returns the index its first vertex gets.
    pub(super) fn push_mesh(&mut self, mesh: &Mesh) -> u32 {
        let base = self.normals.len();
        let count = mesh.positions.len();
        if mesh.normals.len() == count {
            self.normals.par_extend(mesh.normals.par_iter().map(|n| n.to_array()));
        } else {
            self.normals.resize(base + count, [0.0; 3]);
        }
        if mesh.texcoords.len() == count && count > 0 {
            self.texcoords.resize(base, [0.0; 2]);
            self.texcoords.extend(mesh.texcoords.iter().map(|t| t.to_array()));
        }
        if mesh.colors.len() == count && count > 0 {
            self.colors.resize(base, [255; 4]);
            self.colors.extend_from_slice(&mesh.colors);
        }
        base as u32
    }

    /// Fill the attributes of the last meshes that lacked them up to the vertex count.
    pub(super) fn finish(&mut self) {
        let count = self.normals.len();
        if !self.texcoords.is_empty() {
            self.texcoords.resize(count, [0.0; 2]);
        }
        if !self.colors.is_empty() {
            self.colors.resize(count, [255; 4]);
        }
    }
}

/// A Blinn–Phong material with its diffuse texture and how that is laid on (64 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    pub(crate) diffuse: [f32; 3],
    pub(crate) mirror: f32,
    pub(crate) specular: [f32; 3],
    pub(crate) shininess: f32,
    /// Diffuse texture index into the atlas, or `NO_TEXTURE`.
    pub(crate) texture: u32,
    /// `contract::TEXTURE_CLAMP` when the texture clamps instead of repeating,
    /// `contract::MATERIAL_VERTEX_COLORS` when the mesh's vertex colours tint it.
    pub(crate) texture_flags: u32,
    pub(crate) _pad: [u32; 2],
    /// Texture coordinates are `uv * uv_scale + uv_offset` before the lookup
    /// (`TextureTransform`).
    pub(crate) uv_scale: [f32; 2],
    /// Added to the scaled texture coordinates (`map_Kd -o`).
    pub(crate) uv_offset: [f32; 2],
}

impl GpuMaterial {
    /// `m` as the shader reads it, with its diffuse texture's index in the atlas (or
    /// [`NO_TEXTURE`]); `vertex_colors` when its mesh's vertex colours tint it.
    pub(crate) fn new(m: &Material, texture: u32, vertex_colors: bool) -> Self {
        let clamp = if m.texture_transform.clamp { crate::contract::TEXTURE_CLAMP } else { 0 };
        let colors = if vertex_colors { crate::contract::MATERIAL_VERTEX_COLORS } else { 0 };
        GpuMaterial {
            diffuse: m.diffuse.to_array(),
            mirror: m.mirror,
            specular: m.specular.to_array(),
            shininess: m.shininess,
            texture,
            texture_flags: clamp | colors,
            _pad: [0; 2],
            uv_scale: m.texture_transform.scale.to_array(),
            uv_offset: m.texture_transform.offset.to_array(),
        }
    }

    /// The texture coordinates the lookup uses for the surface's `uv` (the shader's
    /// `material_uv`).
    pub(crate) fn texture_uv(&self, uv: Vec2) -> Vec2 {
        uv * Vec2::from(self.uv_scale) + Vec2::from(self.uv_offset)
    }

    /// True when the texture clamps at its edges instead of repeating.
    pub(crate) fn texture_clamps(&self) -> bool {
        self.texture_flags & crate::contract::TEXTURE_CLAMP != 0
    }

    /// True when the mesh's vertex colours multiply the diffuse colour.
    pub(crate) fn has_vertex_colors(&self) -> bool {
        self.texture_flags & crate::contract::MATERIAL_VERTEX_COLORS != 0
    }
}

/// `GpuMaterial::texture` of an untextured material (the shader compares it with `EMPTY`).
pub(crate) const NO_TEXTURE: u32 = crate::contract::EMPTY;

/// A placed mesh (64 bytes): the world-to-object transform that carries rays into the
/// mesh, and where the traversal finds the mesh's trees and triangles. Its world box is in
/// the top level's nodes; what is the same for every copy (brute force's count, the prim-id
/// base) is in the mesh's [`GpuMesh`], so that a field of 10,000 copies costs at most 128
/// bytes a copy.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuInstance {
    /// World to object, three rows of a 3x4 matrix: `object = rows * (world, 1)`. Normals go
    /// back to world space by the transpose of its 3x3 part (the inverse transpose of the
    /// instance's transform).
    pub(crate) to_object: [[f32; 4]; 3],
    /// The mesh's binary root, or `EMPTY` for a mesh without triangles (nothing to visit).
    pub node_base: u32,
    pub triangle_base: u32,
    /// The mesh's first wide node, in 16-byte words of the node buffer, or `EMPTY` for a
    /// mesh without a wide tree.
    pub(crate) wide_words: u32,
    /// The mesh's index in the mesh table ([`GpuMesh`]).
    pub mesh: u32,
}

/// What is the same for every instance of a mesh (16 bytes a mesh).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMesh {
    /// Triangle slots from the instances' `triangle_base` (more than the mesh's triangles
    /// where the build cut some into pieces: one slot per leaf that holds a piece): what
    /// brute force walks.
    pub triangle_count: u32,
    /// Added to a triangle's file-order index to give the prim-id AOV.
    pub(crate) prim_base: u32,
    /// `CONVEX_OUTWARD` or `CONVEX_INWARD` for a convex mesh, whose instance a ray that
    /// leaves it from outside skips (`tracer/convex.rs`); else 0.
    pub(crate) convex: u32,
    pub(crate) _unused: u32,
}

impl GpuInstance {
    /// A world-space point in the mesh's space.
    pub(crate) fn point_to_object(&self, p: Vec3) -> Vec3 {
        let [x, y, z] = self.to_object.map(|r| Vec3::new(r[0], r[1], r[2]).dot(p) + r[3]);
        Vec3::new(x, y, z)
    }

    /// A world-space direction in the mesh's space (not normalised: ray parameters stay
    /// world distances).
    pub(crate) fn vector_to_object(&self, d: Vec3) -> Vec3 {
        let [x, y, z] = self.to_object.map(|r| Vec3::new(r[0], r[1], r[2]).dot(d));
        Vec3::new(x, y, z)
    }

    /// An object-space normal in world space (not normalised): the transpose of the
    /// world-to-object part.
    pub(crate) fn normal_to_world(&self, n: Vec3) -> Vec3 {
        let [r0, r1, r2] = self.to_object.map(|r| Vec3::new(r[0], r[1], r[2]));
        r0 * n.x + r1 * n.y + r2 * n.z
    }

    /// Object to world, the inverse of `to_object` (in double precision), as three rows of a
    /// 3x4 matrix: what the driver's instances take.
    pub(crate) fn world_rows(&self) -> [f32; 12] {
        let r = self.to_object.map(|r| r.map(f64::from));
        let m = glam::DMat3::from_cols_array(&[
            r[0][0], r[1][0], r[2][0], r[0][1], r[1][1], r[2][1], r[0][2], r[1][2], r[2][2],
        ]);
        let inverse =
            glam::DAffine3 { matrix3: m, translation: glam::DVec3::new(r[0][3], r[1][3], r[2][3]) }
                .inverse();
        let (m, t) = (inverse.matrix3, inverse.translation);
        let row = |i: usize| [m.x_axis[i], m.y_axis[i], m.z_axis[i], t[i]].map(|v| v as f32);
        let [a, b, c] = [row(0), row(1), row(2)];
        [a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3], c[0], c[1], c[2], c[3]]
    }

    /// Area in world space of an object-space parallelogram with (unnormalised) normal
    /// `cross`: |W^T cross| / |det W| for the world-to-object part W.
    pub(crate) fn world_area(&self, cross: Vec3) -> f32 {
        let [r0, r1, r2] = self.to_object.map(|r| Vec3::new(r[0], r[1], r[2]));
        self.normal_to_world(cross).length() / r0.dot(r1.cross(r2)).abs()
    }
}

/// One triangle's traversal record and shading record (`prim` in file order; the mesh's
/// vertices start at `vertex_base`).
pub(super) fn pack_triangle(
    mesh: &Mesh,
    prim: u32,
    material_base: u32,
    vertex_base: u32,
) -> (GpuTriangle, GpuTriangleShading) {
    (triangle_record(mesh, prim), shading_record(mesh, prim, material_base, vertex_base))
}

/// Triangle `prim` (file order) of `mesh` as the traversal reads it.
pub(super) fn triangle_record(mesh: &Mesh, prim: u32) -> GpuTriangle {
    let [a, b, c] = mesh.corners(prim as usize);
    let (mut e1, mut e2) = (b - a, c - a);
    // A (nearly) degenerate triangle would pass Möller–Trumbore's absolute determinant test
    // on rounding noise and report hits far outside itself: zero its edges so that both
    // tracers skip it.
    if e1.cross(e2).length() <= 1e-7 * e1.length() * e2.length() {
        (e1, e2) = (Vec3::ZERO, Vec3::ZERO);
    }
    GpuTriangle { v0: a.to_array(), e1: e1.to_array(), e2: e2.to_array(), prim }
}

/// Triangle `prim`'s hit record, its mesh's vertices and materials starting at the bases.
pub(super) fn shading_record(
    mesh: &Mesh,
    prim: u32,
    material_base: u32,
    vertex_base: u32,
) -> GpuTriangleShading {
    GpuTriangleShading {
        corners: mesh.triangles[prim as usize].map(|k| vertex_base + k),
        material: material_base + mesh.triangle_materials.get(prim as usize).copied().unwrap_or(0),
    }
}

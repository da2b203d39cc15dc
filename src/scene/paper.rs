//! The paper's experiment scene (section 4): a model at the centre of a box of six mirror
//! planes, optional identical copies along the x, y and z axes at a fixed spacing, and a
//! point light orbiting inside the box. Every entry point opens on this scene.

use std::path::PathBuf;

use glam::Vec3;

use super::primitives::PaperModel;
use super::{Camera, Instance, Material, Mesh, PointLight, Scene};

/// Half the side of the mirror box.
pub const BOX_HALF_SIZE: f32 = 4.0;
/// Every model is scaled so its largest half-extent is this.
pub const MODEL_RADIUS: f32 = 1.0;
/// Distance between a copy and the centre model (Table 2's fixed spacing).
pub(crate) const MODEL_SPACING: f32 = 2.5;
/// Copies fill a 3x3x3 lattice inside the box: centre, the six axis neighbours, then the
/// edges and corners (as many as `render_settings::MODELS` accepts).
pub use crate::render_settings::MAX_MODELS;

/// Where the model comes from: one of the paper's generated primitives or a model file
/// (OBJ, PLY or glTF).
#[derive(Clone, Debug, PartialEq)]
pub enum ModelSource {
    /// One of the paper's models, made in code.
    Paper(PaperModel),
    /// A model file, its format chosen by its extension (`formats.rs`).
    File(PathBuf),
    /// A finely tessellated torus knot of at least this many triangles (`torusknot:N`),
    /// for scaling tests without downloads.
    Generated(usize),
}

impl ModelSource {
    /// Parse a `--model` value: a paper model name, `torusknot:N` (N triangles, `k`/`M`
    /// suffixes allowed), else a path.
    pub fn parse(s: &str) -> Self {
        if let Some(n) = s.strip_prefix("torusknot:").and_then(parse_count) {
            return ModelSource::Generated(n);
        }
        match PaperModel::from_name(s) {
            Some(m) => ModelSource::Paper(m),
            None => ModelSource::File(PathBuf::from(s)),
        }
    }

    /// Short name for file names and the panel.
    pub fn label(&self) -> String {
        match self {
            ModelSource::Paper(m) => m.name().to_string(),
            // Named by what it has: `torusknot:1` makes 512 triangles.
            ModelSource::Generated(n) => {
                format!("torusknot-{}", super::primitives::large_torus_knot_triangles(*n))
            }
            ModelSource::File(p) => {
                p.file_stem().map_or("model".into(), |s| s.to_string_lossy().into_owned())
            }
        }
    }
}

/// "4000000", "250k", "4M" -> a count (at most 100 million, at least 1).
fn parse_count(s: &str) -> Option<usize> {
    let s = s.trim();
    let (digits, scale) = match s.chars().last()? {
        'k' | 'K' => (&s[..s.len() - 1], 1_000.0),
        'm' | 'M' => (&s[..s.len() - 1], 1_000_000.0),
        _ => (s, 1.0),
    };
    let v = digits.parse::<f64>().ok()? * scale;
    (v.is_finite() && (1.0..=1e8).contains(&v)).then_some(v as usize)
}

impl Default for ModelSource {
    fn default() -> Self {
        ModelSource::Paper(PaperModel::Geosphere)
    }
}

/// The model's look where the file does not give one: a warm, glossy plastic.
pub(crate) fn model_material() -> Material {
    Material {
        name: "model".into(),
        diffuse: Vec3::new(0.85, 0.45, 0.2),
        specular: Vec3::splat(0.6),
        shininess: 48.0,
        mirror: 1.0,
        diffuse_texture: None,
        ..Material::default()
    }
}

/// The mirror planes' material: a dim diffuse base so the reflections dominate.
pub(crate) fn mirror_material() -> Material {
    Material {
        name: "mirror".into(),
        diffuse: Vec3::new(0.25, 0.27, 0.32),
        specular: Vec3::splat(0.3),
        shininess: 64.0,
        mirror: 1.0,
        diffuse_texture: None,
        ..Material::default()
    }
}

/// Normalise size and give materials that are only defaults the model look.
pub fn prepare_model(mesh: &mut Mesh) {
    mesh.normalize_to(MODEL_RADIUS);
    let default = Material::default();
    let all_default = mesh
        .materials
        .iter()
        .all(|m| Material { name: default.name.clone(), ..m.clone() } == default);
    if all_default {
        for m in &mut mesh.materials {
            *m = Material { name: m.name.clone(), ..model_material() };
        }
    }
}

/// The point light's orbit: a horizontal circle inside the box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightOrbit {
    pub radius: f32,
    pub height: f32,
    /// Position along the orbit in degrees (0 = +x, 90 = +z).
    pub angle_deg: f32,
}

impl Default for LightOrbit {
    fn default() -> Self {
        Self { radius: 2.8, height: 2.4, angle_deg: 45.0 }
    }
}

impl LightOrbit {
    /// The light's position at the current angle.
    pub fn position(&self) -> Vec3 {
        let a = self.angle_deg.to_radians();
        Vec3::new(self.radius * a.cos(), self.height, self.radius * a.sin())
    }
}

/// Offsets of the first `count` models: centre, +x, +y, +z, -x, -y, -z, then the rest of
/// the 3x3x3 lattice (edges before corners), `MODEL_SPACING` apart.
pub fn model_offsets(count: u32) -> Vec<Vec3> {
    let mut cells: Vec<Vec3> = Vec::with_capacity(27);
    for x in -1i32..=1 {
        for y in -1i32..=1 {
            for z in -1i32..=1 {
                cells.push(Vec3::new(x as f32, y as f32, z as f32));
            }
        }
    }
    // Order by distance from the centre; among equals, positive axes first as in Table 2.
    let axis_rank = |v: &Vec3| {
        let order = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z];
        order.iter().position(|a| a == v).unwrap_or(6)
    };
    cells.sort_by(|a, b| {
        let ka = (a.length_squared() as i32, axis_rank(a));
        let kb = (b.length_squared() as i32, axis_rank(b));
        ka.cmp(&kb).then(a.to_array().partial_cmp(&b.to_array()).unwrap())
    });
    cells.into_iter().take(count.min(MAX_MODELS) as usize).map(|c| c * MODEL_SPACING).collect()
}

/// Six inward-facing planes closing a cube of half-size `half` (12 triangles). Each face
/// has its own four vertices with the face's normal, so the mirrors stay flat under
/// smooth shading.
pub(crate) fn mirror_box(half: f32) -> Mesh {
    let h = half;
    let positions: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 != 0 { h } else { -h },
                if i & 2 != 0 { h } else { -h },
                if i & 4 != 0 { h } else { -h },
            )
        })
        .collect();
    // Each face as a quad wound to face the inside, split as the paper splits quads.
    let quads: [[u32; 4]; 6] = [
        [0, 2, 6, 4], // -x
        [1, 5, 7, 3], // +x
        [0, 4, 5, 1], // -y
        [2, 3, 7, 6], // +y
        [0, 1, 3, 2], // -z
        [4, 6, 7, 5], // +z
    ];
    let mut face_positions = Vec::with_capacity(24);
    let mut normals = Vec::with_capacity(24);
    let mut triangles = Vec::with_capacity(12);
    for q in quads {
        let corners = q.map(|i| positions[i as usize]);
        let n = (corners[1] - corners[0]).cross(corners[3] - corners[0]).normalize();
        let base = face_positions.len() as u32;
        face_positions.extend(corners);
        normals.extend([n; 4]);
        // Split as the paper splits quads: (1,2,4) and (2,3,4).
        triangles.push([base, base + 1, base + 3]);
        triangles.push([base + 1, base + 2, base + 3]);
    }
    Mesh {
        name: "mirror box".into(),
        positions: face_positions,
        normals,
        triangle_materials: vec![0; triangles.len()],
        triangles,
        materials: vec![mirror_material()],
        ..Default::default()
    }
}

/// The camera the scene opens with: inside the box, looking at the centre model.
pub(crate) fn default_camera() -> Camera {
    Camera {
        position: Vec3::new(2.2, 1.5, 3.3),
        target: Vec3::new(0.0, 0.0, 0.0),
        up: Vec3::Y,
        vfov_deg: 60.0,
    }
}

/// The model's index in the paper scene's mesh list; the mirror box is [`MIRROR_BOX_MESH`].
pub(crate) const MODEL_MESH: usize = 0;
/// The mirror box's index in the paper scene's mesh list.
pub(crate) const MIRROR_BOX_MESH: usize = 1;

/// Instances for `model_count` copies: the models (mesh 0), then the box (mesh 1). Models
/// come first so their hits shorten the ray before the box, which every ray meets.
pub fn instances(model_count: u32) -> Vec<Instance> {
    model_offsets(model_count)
        .into_iter()
        .map(|t| Instance { mesh: MODEL_MESH, translation: t, scale: 1.0 })
        .chain(std::iter::once(Instance {
            mesh: MIRROR_BOX_MESH,
            translation: Vec3::ZERO,
            scale: 1.0,
        }))
        .collect()
}

/// The paper's scene without its mirror box: the model(s) alone, so that an environment
/// map is seen around them and in their reflections.
pub fn open_scene(model: Mesh, model_count: u32, light: LightOrbit) -> Scene {
    paper_scene(model, model_count, light).without_box()
}

/// The paper's scene around an already prepared model mesh.
pub fn paper_scene(model: Mesh, model_count: u32, light: LightOrbit) -> Scene {
    Scene {
        meshes: vec![model, mirror_box(BOX_HALF_SIZE)],
        instances: instances(model_count),
        camera: default_camera(),
        light: PointLight { position: light.position(), color: Vec3::ONE },
        background: Vec3::ZERO,
        ambient: 0.1,
        environment: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_models_parse_with_suffixes() {
        assert_eq!(ModelSource::parse("torusknot:4M"), ModelSource::Generated(4_000_000));
        assert_eq!(ModelSource::parse("torusknot:250k"), ModelSource::Generated(250_000));
        for n in [1, 1000, 250_000] {
            let label = ModelSource::Generated(n).label();
            assert_eq!(
                label,
                format!(
                    "torusknot-{}",
                    super::super::primitives::large_torus_knot(n).triangle_count()
                ),
                "the name counts what is made"
            );
        }
        assert_eq!(ModelSource::parse("torusknot"), ModelSource::Paper(PaperModel::TorusKnot));
        // Out of range or not a number: taken as a file name (which then fails to open).
        assert!(matches!(ModelSource::parse("torusknot:0"), ModelSource::File(_)));
        assert!(matches!(ModelSource::parse("torusknot:1e12"), ModelSource::File(_)));
    }

    #[test]
    fn copies_follow_the_axes_and_stay_inside_the_box() {
        let o = model_offsets(7);
        assert_eq!(o[0], Vec3::ZERO);
        assert_eq!(o[1], Vec3::X * MODEL_SPACING);
        assert_eq!(o[2], Vec3::Y * MODEL_SPACING);
        assert_eq!(o[3], Vec3::Z * MODEL_SPACING);
        assert_eq!(o[4], -Vec3::X * MODEL_SPACING);
        let all = model_offsets(MAX_MODELS);
        assert_eq!(all.len(), 27);
        for off in all {
            assert!(off.abs().max_element() + MODEL_RADIUS < BOX_HALF_SIZE);
        }
    }

    #[test]
    fn mirror_box_is_closed_and_faces_inward() {
        let b = mirror_box(2.0);
        assert_eq!(b.triangle_count(), 12);
        for i in 0..12 {
            let [a, c1, c2] = b.corners(i);
            let n = (c1 - a).cross(c2 - a);
            let centre = (a + c1 + c2) / 3.0;
            assert!(n.dot(-centre) > 0.0, "face {i} points outward");
            // Flat under smooth shading: every corner normal is the face normal.
            for k in b.triangles[i] {
                assert!((b.normals[k as usize] - n.normalize()).length() < 1e-6);
            }
        }
    }

    #[test]
    fn light_orbit_is_a_circle_at_its_height() {
        let l = LightOrbit { radius: 2.0, height: 1.0, angle_deg: 90.0 };
        assert!((l.position() - Vec3::new(0.0, 1.0, 2.0)).length() < 1e-5);
    }
}

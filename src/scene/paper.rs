//! The paper's experiment scene (section 4): a model at the centre of a box of six mirror
//! planes, optional identical copies along the x, y and z axes at a fixed spacing, and a
//! point light orbiting inside the box. Every entry point opens on this scene.

use std::path::PathBuf;

use glam::{Affine3A, Vec3};

use super::primitives::PaperModel;
use super::{Assembly, Camera, Instance, Material, Mesh, Model, PointLight, Scene};

/// Half the side of the mirror box.
pub const BOX_HALF_SIZE: f32 = 4.0;
/// Every model is scaled so its largest half-extent is this.
pub const MODEL_RADIUS: f32 = 1.0;
/// Distance between a copy and the centre model (Table 2's fixed spacing).
pub(crate) const MODEL_SPACING: f32 = 2.5;
/// Copies fill a 3x3x3 lattice inside the box: centre, the six axis neighbours, then the
/// edges and corners; more grow it into a field (as many as `render_settings::MODELS`
/// accepts).
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

/// The model's cameras moved and scaled as [`prepare_model`] fits the model (the box's
/// centre to the origin, its largest half-extent to [`MODEL_RADIUS`]), each looking at the
/// point of its view line nearest the model's centre (where the window orbits).
fn fit_cameras(model: &mut Model) {
    let b = model.bounds();
    if model.cameras.is_empty() || b.is_empty() {
        return;
    }
    let half = (b.max - b.min).max_element() * 0.5;
    let s = if half > 0.0 { MODEL_RADIUS / half } else { 1.0 };
    let centre = (b.min + b.max) * 0.5;
    for camera in &mut model.cameras {
        let forward = (camera.target - camera.position).normalize_or_zero();
        camera.position = (camera.position - centre) * s;
        let along = (-camera.position).dot(forward).max(0.1 * MODEL_RADIUS);
        camera.target = camera.position + forward * along;
    }
}

/// Normalise size (the model's box centred, its largest half-extent [`MODEL_RADIUS`]) and
/// give materials that are only defaults the model look. A one-mesh model's vertices are
/// moved; a model of parts keeps its meshes and has its parts' transforms adjusted.
pub fn prepare_model(model: &mut Model) {
    fit_cameras(model);
    if model.is_single_mesh() {
        model.meshes[0].normalize_to(MODEL_RADIUS);
    } else {
        let b = model.bounds();
        if !b.is_empty() {
            let half = (b.max - b.min).max_element() * 0.5;
            let s = if half > 0.0 { MODEL_RADIUS / half } else { 1.0 };
            let fit = Affine3A::from_scale(Vec3::splat(s))
                * Affine3A::from_translation(-(b.min + b.max) * 0.5);
            for part in &mut model.parts {
                part.transform = fit * part.transform;
            }
        }
    }
    let default = Material::default();
    let all_default = model
        .meshes
        .iter()
        .flat_map(|m| &m.materials)
        .all(|m| Material { name: default.name.clone(), ..m.clone() } == default);
    if all_default {
        for m in model.meshes.iter_mut().flat_map(|m| &mut m.materials) {
            *m = Material { name: m.name.clone(), ..model_material() };
        }
    }
}

/// [`prepare_model`] for a model of one mesh.
pub fn prepare_mesh(mesh: &mut Mesh) {
    let mut model = Model::from(std::mem::take(mesh));
    prepare_model(&mut model);
    *mesh = model.meshes.swap_remove(0);
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
/// the 3x3x3 lattice (edges before corners), `MODEL_SPACING` apart: the paper's Table 2
/// layout. Past 27 the lattice grows into a field: the cells of a cubic grid in order of
/// distance from the centre, so a larger count only appends copies.
pub fn model_offsets(count: u32) -> Vec<Vec3> {
    let count = count.min(MAX_MODELS) as usize;
    // The smallest grid holding `count` cells within its inscribed sphere's shells: 3x3x3
    // up to 27 (the paper's), larger beyond.
    let half = if count <= 27 { 1 } else { ((count as f64).cbrt() * 0.75).ceil() as i32 + 1 };
    let mut cells: Vec<[i32; 3]> = Vec::with_capacity((2 * half as usize + 1).pow(3));
    for x in -half..=half {
        for y in -half..=half {
            for z in -half..=half {
                cells.push([x, y, z]);
            }
        }
    }
    // Order by distance from the centre; among equals, positive axes first as in Table 2.
    let axis_rank = |c: &[i32; 3]| {
        let order = [[1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, 0, 0], [0, -1, 0], [0, 0, -1]];
        order.iter().position(|a| a == c).unwrap_or(6)
    };
    let key = |c: &[i32; 3]| (c.iter().map(|v| v * v).sum::<i32>(), axis_rank(c), *c);
    if count < cells.len() {
        cells.select_nth_unstable_by_key(count, key);
        cells.truncate(count);
    }
    cells.sort_unstable_by_key(key);
    cells
        .into_iter()
        .map(|c| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) * MODEL_SPACING)
        .collect()
}

/// How far the default camera steps back for `count` copies, as a factor of its distance:
/// 1 up to the paper's 27; for a field, far enough that the field's bounding sphere fits
/// the opening view's 60 degrees.
pub fn camera_scale(count: u32) -> f32 {
    camera_scale_of(&model_offsets(count))
}

/// [`camera_scale`] for the copies at `offsets` (`model_offsets`' list).
fn camera_scale_of(offsets: &[Vec3]) -> f32 {
    if offsets.len() <= 27 {
        return 1.0;
    }
    let radius = offsets.iter().map(|o| o.length()).fold(0.0, f32::max) + MODEL_RADIUS;
    let half_fov = (default_camera().vfov_deg * 0.5).to_radians();
    radius / half_fov.sin() * 1.05 / default_camera().position.length()
}

/// How much the mirror box grows for `count` copies: 1 up to the paper's 27; for a field,
/// enough to hold every copy and the stepped-back camera ([`camera_scale`]), which must
/// see the mirrors from inside.
pub fn field_scale(count: u32) -> f32 {
    field_scale_of(&model_offsets(count))
}

/// [`field_scale`] for the copies at `offsets`: the field's layout is made once per count.
fn field_scale_of(offsets: &[Vec3]) -> f32 {
    if offsets.len() <= 27 {
        return 1.0;
    }
    let reach = offsets.iter().map(|o| o.abs().max_element()).fold(0.0, f32::max);
    let eye = default_camera().position.abs().max_element() * camera_scale_of(offsets);
    ((reach + MODEL_RADIUS).max(eye) + 0.5) / BOX_HALF_SIZE
}

/// The transform of copy `index` of a field scattered with `seed` (0: none, the paper's
/// identical copies): a random rotation and a uniform scale of 0.5 to 1, drawn from the
/// seed and the index alone, so that every tracer and run places the same field.
pub fn scatter(index: u32, seed: u32) -> Affine3A {
    if seed == 0 {
        return Affine3A::IDENTITY;
    }
    // SplitMix64 over (seed, index): numbers in [0, 1) with 24 bits each.
    let mut state = (u64::from(seed) << 32) | u64::from(index);
    let mut next = || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u32 << 24) as f32
    };
    // A uniformly random rotation (Shoemake's subgroup algorithm).
    let (u1, u2, u3) = (next(), next(), next());
    let tau = std::f32::consts::TAU;
    let rotation = glam::Quat::from_xyzw(
        (1.0 - u1).sqrt() * (tau * u2).sin(),
        (1.0 - u1).sqrt() * (tau * u2).cos(),
        u1.sqrt() * (tau * u3).sin(),
        u1.sqrt() * (tau * u3).cos(),
    );
    let scale = 0.5 + 0.5 * next();
    Affine3A::from_scale_rotation_translation(Vec3::splat(scale), rotation.normalize(), Vec3::ZERO)
}

/// Six inward-facing planes closing a cube of half-size `half` (12 triangles). Each face
/// has its own four vertices with the face's normal, so the mirrors stay flat under
/// smooth shading.
pub(crate) fn mirror_box_mesh(half: f32) -> Mesh {
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

/// The model's index in the paper scene's mesh list (its first, for a model of several
/// meshes); the mirror box follows the model's meshes.
pub(crate) const MODEL_MESH: usize = 0;

/// The instances of `count` copies of `assembly`'s model, copy `i` turned and scaled by
/// [`scatter`] with `seed`, then (with `mirror_box`) the box, grown to hold a field
/// ([`field_scale`]), then the other objects. Copies come first, each its parts in order,
/// so that copy `i` of a one-part model is instance `i`.
pub fn place(assembly: &Assembly, count: u32, seed: u32, mirror_box: bool) -> Vec<Instance> {
    let offsets = model_offsets(count);
    let box_scale = field_scale_of(&offsets);
    let copies = offsets.into_iter().enumerate().flat_map(|(i, offset)| {
        let copy = Affine3A::from_translation(offset) * scatter(i as u32, seed);
        assembly
            .model_parts
            .iter()
            .map(move |part| Instance { mesh: part.mesh, transform: copy * part.transform })
    });
    let mirror = assembly
        .mirror_box
        .filter(|_| mirror_box)
        .map(|mesh| Instance::placed(mesh, Vec3::ZERO, box_scale));
    copies.chain(mirror).chain(assembly.objects.iter().copied()).collect()
}

/// What the paper's scene of a one-mesh model is made of: the model (mesh 0) and the
/// mirror box (mesh 1).
fn paper_assembly() -> Assembly {
    Assembly {
        model_parts: vec![Instance::placed(MODEL_MESH, Vec3::ZERO, 1.0)],
        mirror_box: Some(1),
        objects: Vec::new(),
    }
}

/// Instances for `model_count` copies of a one-mesh model: the models (mesh 0), each
/// turned and scaled by [`scatter`] with `seed`, then the box (mesh 1) ([`place`]).
pub fn instances(model_count: u32, seed: u32) -> Vec<Instance> {
    place(&paper_assembly(), model_count, seed, true)
}

/// The paper's scene without its mirror box: the model(s) alone, so that an environment
/// map is seen around them and in their reflections.
pub fn open_scene(model: Mesh, model_count: u32, light: LightOrbit) -> Scene {
    paper_scene(model, model_count, light).without_box()
}

/// The paper's scene around an already prepared model mesh.
pub fn paper_scene(model: Mesh, model_count: u32, light: LightOrbit) -> Scene {
    scattered_scene(model, model_count, 0, light)
}

/// [`paper_scene`] with its copies turned and scaled by [`scatter`] with `seed`.
pub fn scattered_scene(model: Mesh, model_count: u32, seed: u32, light: LightOrbit) -> Scene {
    assembled_scene(model.into(), &[], &[], model_count, seed, light)
}

/// The paper's scene of `count` copies of `model` (any number of meshes and parts) and the
/// mirror box, with objects placed beside them: each a model (`None`: the main one,
/// `Some(k)`: `others[k]`) and its world transform. Meshes are stored once: the model's,
/// the box, then each of `others`' in order.
pub fn assembled_scene(
    model: Model,
    others: &[Model],
    objects: &[(Option<usize>, Affine3A)],
    count: u32,
    seed: u32,
    light: LightOrbit,
) -> Scene {
    let mut meshes = model.meshes;
    let mirror_box = meshes.len();
    meshes.push(mirror_box_mesh(BOX_HALF_SIZE));
    let mut bases = Vec::with_capacity(others.len());
    for other in others {
        bases.push(meshes.len());
        meshes.extend(other.meshes.iter().cloned());
    }
    let mut placed = Vec::new();
    for &(which, transform) in objects {
        let (parts, base) = match which {
            None => (&model.parts, 0),
            Some(k) => (&others[k].parts, bases[k]),
        };
        placed.extend(
            parts
                .iter()
                .map(|p| Instance { mesh: base + p.mesh, transform: transform * p.transform }),
        );
    }
    let assembly =
        Assembly { model_parts: model.parts, mirror_box: Some(mirror_box), objects: placed };
    Scene {
        instances: place(&assembly, count, seed, true),
        meshes,
        camera: default_camera(),
        light: PointLight { position: light.position(), color: Vec3::ONE },
        background: Vec3::ZERO,
        ambient: 0.1,
        environment: None,
        assembly,
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
        let all = model_offsets(27);
        assert_eq!(all.len(), 27);
        for off in all {
            assert!(off.abs().max_element() + MODEL_RADIUS < BOX_HALF_SIZE);
        }
    }

    #[test]
    fn a_field_grows_the_box_and_scattering_is_seeded() {
        let field = instances(1000, 0);
        assert_eq!(field.len(), 1001);
        let box_scale = field_scale(1000);
        assert!(box_scale > 3.0, "{box_scale}");
        assert_eq!(field[1000].transform.matrix3.x_axis.x, box_scale, "the box grows");
        // The stepped-back camera is inside the box and has every copy in its view.
        let eye = default_camera().position * camera_scale(1000);
        assert!(eye.abs().max_element() < BOX_HALF_SIZE * box_scale);
        let half_fov = (default_camera().vfov_deg * 0.5).to_radians();
        for offset in model_offsets(1000) {
            let angle = (offset - eye).angle_between(-eye);
            assert!(angle + MODEL_RADIUS / (offset - eye).length() < half_fov, "{offset}");
        }
        // Seed 0 keeps the paper's identical copies; a seed turns and scales each copy the
        // same way every time, and differently per copy.
        assert!(field[..1000].iter().all(|i| i.transform.matrix3 == glam::Mat3A::IDENTITY));
        let (a, b) = (instances(30, 7), instances(30, 7));
        assert_eq!(a, b);
        assert_ne!(a[3].transform.matrix3, a[4].transform.matrix3);
        assert_ne!(instances(30, 8)[3], a[3]);
        for inst in &a[..30] {
            let scale = inst.transform.matrix3.x_axis.length();
            assert!((0.5..=1.0).contains(&scale), "{scale}");
            assert!(
                (inst.transform.matrix3.determinant() - scale.powi(3)).abs() < 1e-4,
                "a rotation, not a mirror"
            );
        }
    }

    #[test]
    fn mirror_box_is_closed_and_faces_inward() {
        let b = mirror_box_mesh(2.0);
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

//! Presets: everything that decides an image (model and copies, resolution, bounces, blend,
//! acceleration, shading, environment, light, camera) as one human-readable TOML file with
//! a format version. The PNGs the program writes carry exactly this text in their
//! `meshtracer` chunk, so a PNG is a preset too.
//!
//! Reading is strict about values and lenient about form: keys left out keep the paper's
//! defaults, unknown keys are reported as warnings (a typo must not pass unnoticed, nor
//! stop a render), and a bad value is one line naming the key and the line.

use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::obj::LoadOptions;
use super::paper::{LightOrbit, ModelSource};
use super::spec::{CameraSpec, ObjectSpec, Placement, SceneSpec};
use super::EnvironmentSource;
use crate::render_settings::{Accel, Aov, BvhLayout, RenderSettings};
use fields::{
    de_accumulate, de_ao_radius, de_ao_samples, de_blend, de_bounces, de_copies, de_crease_angle,
    de_env, de_finite, de_fov, de_from_str, de_light_height, de_light_radius, de_model, de_point,
    de_scale, de_side, de_spp, de_version, is_one, is_zero, ser_display, ser_env, ser_model,
};

mod fields;

/// The format version this build writes and reads (`version = 1`).
pub(crate) const VERSION: u32 = 1;

/// The first lines of every preset: what the file is and how to use it.
const HEADER: &str =
    "# meshtracer preset: `meshtracer view|render|bench --preset THIS_FILE`; flags beside it\n\
# override it. Keys left out keep their defaults; a relative path is read from this file's folder\n\
# (or, failing that, the working folder).\n";

/// The file as serde sees it: one table per panel section.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
struct File {
    #[serde(deserialize_with = "de_version")]
    version: u32,
    model: ModelPart,
    image: ImagePart,
    tracing: TracingPart,
    shading: ShadingPart,
    light: LightPart,
    camera: CameraPart,
    /// Other models placed in the scene: `[[object]]` tables, written last (TOML puts
    /// arrays of tables after the plain tables).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    object: Vec<ObjectPart>,
}

/// One `[[object]]`: a model and its transform (scale, then rotation in degrees about x,
/// y, z, then translation).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct ObjectPart {
    #[serde(serialize_with = "ser_model", deserialize_with = "de_model")]
    model: ModelSource,
    #[serde(default, deserialize_with = "de_point")]
    translate: [f32; 3],
    #[serde(default, deserialize_with = "de_point")]
    rotate: [f32; 3],
    #[serde(default = "unit_scale", deserialize_with = "de_scale")]
    scale: [f32; 3],
}

fn unit_scale() -> [f32; 3] {
    [1.0; 3]
}

impl ObjectPart {
    fn from_spec(object: &ObjectSpec) -> Self {
        let p = &object.placement;
        ObjectPart {
            model: object.model.clone(),
            translate: p.translate.to_array(),
            rotate: p.rotate.to_array(),
            scale: p.scale.to_array(),
        }
    }

    fn into_spec(self) -> ObjectSpec {
        ObjectSpec {
            model: self.model,
            placement: Placement {
                translate: Vec3::from(self.translate),
                rotate: Vec3::from(self.rotate),
                scale: Vec3::from(self.scale),
            },
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
struct ModelPart {
    /// `--model` spelling: a paper model, torusknot:N or an .obj path.
    #[serde(serialize_with = "ser_model", deserialize_with = "de_model")]
    source: ModelSource,
    /// `--crease-angle`: written only when set (TOML has no "none").
    #[serde(skip_serializing_if = "Option::is_none", deserialize_with = "de_crease_angle")]
    crease_angle: Option<f32>,
    #[serde(deserialize_with = "de_copies")]
    copies: u32,
    /// `--scatter`: written only when set.
    #[serde(skip_serializing_if = "is_zero")]
    scatter: u32,
    mirror_box: bool,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
struct ImagePart {
    #[serde(deserialize_with = "de_side")]
    width: u32,
    #[serde(deserialize_with = "de_side")]
    height: u32,
    #[serde(serialize_with = "ser_display", deserialize_with = "de_from_str")]
    aov: Aov,
    /// The AO view's rays per hit (`--ao-samples`).
    #[serde(deserialize_with = "de_ao_samples")]
    ao_samples: u32,
    /// The AO view's radius in scene units (`--ao-radius`).
    #[serde(deserialize_with = "de_ao_radius")]
    ao_radius: f32,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
struct TracingPart {
    #[serde(deserialize_with = "de_bounces")]
    bounces: u32,
    #[serde(deserialize_with = "de_blend")]
    blend: f32,
    #[serde(serialize_with = "ser_display", deserialize_with = "de_from_str")]
    accel: Accel,
    /// `--bvh`: binary, wide or wide-runs; written only when not binary and binary when
    /// absent, so presets written while binary was the default read the same.
    #[serde(
        default = "BvhLayout::binary",
        skip_serializing_if = "BvhLayout::is_binary",
        serialize_with = "ser_display",
        deserialize_with = "de_from_str"
    )]
    bvh: BvhLayout,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
struct ShadingPart {
    smooth: bool,
    textures: bool,
    #[serde(deserialize_with = "de_spp")]
    spp: u32,
    adaptive: bool,
    /// Frames averaged (a screenshot after accumulation); written only when over 1.
    #[serde(skip_serializing_if = "is_one", deserialize_with = "de_accumulate")]
    accumulate: u32,
    /// `--env` spelling: none, sky or an image path.
    #[serde(serialize_with = "ser_env", deserialize_with = "de_env")]
    environment: Option<EnvironmentSource>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
struct LightPart {
    #[serde(deserialize_with = "de_finite")]
    angle: f32,
    #[serde(deserialize_with = "de_light_radius")]
    radius: f32,
    #[serde(deserialize_with = "de_light_height")]
    height: f32,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
struct CameraPart {
    #[serde(deserialize_with = "de_point")]
    eye: [f32; 3],
    #[serde(deserialize_with = "de_point")]
    target: [f32; 3],
    #[serde(deserialize_with = "de_fov")]
    fov: f32,
}

impl File {
    fn from_spec(spec: &SceneSpec) -> Self {
        let s = &spec.settings;
        // Written resolved: a framed or default camera becomes numbers that need no code
        // of this version to mean the same view.
        let camera = spec.camera();
        File {
            version: VERSION,
            model: ModelPart {
                source: spec.model.clone(),
                crease_angle: spec.load_options.crease_angle,
                copies: spec.models,
                scatter: spec.scatter,
                mirror_box: spec.mirror_box,
            },
            image: ImagePart {
                width: s.width,
                height: s.height,
                aov: s.aov,
                ao_samples: s.ao_samples,
                ao_radius: s.ao_radius,
            },
            tracing: TracingPart { bounces: s.bounces, blend: s.blend, accel: s.accel, bvh: s.bvh },
            shading: ShadingPart {
                smooth: s.smooth,
                textures: s.textures,
                spp: s.spp,
                adaptive: s.adaptive,
                accumulate: spec.accumulate,
                environment: spec.environment.clone(),
            },
            light: LightPart {
                angle: spec.light.angle_deg,
                radius: spec.light.radius,
                height: spec.light.height,
            },
            camera: CameraPart {
                eye: camera.position.to_array(),
                target: camera.target.to_array(),
                fov: camera.vfov_deg,
            },
            object: spec.objects.iter().map(ObjectPart::from_spec).collect(),
        }
    }

    fn into_spec(self) -> SceneSpec {
        let File { model, image, tracing, shading, light, camera, object, .. } = self;
        SceneSpec {
            model: model.source,
            load_options: LoadOptions { crease_angle: model.crease_angle },
            models: model.copies,
            scatter: model.scatter,
            objects: object.into_iter().map(ObjectPart::into_spec).collect(),
            mirror_box: model.mirror_box,
            light: LightOrbit {
                radius: light.radius,
                height: light.height,
                angle_deg: light.angle,
            },
            camera: CameraSpec {
                eye: Some(Vec3::from(camera.eye)),
                target: Some(Vec3::from(camera.target)),
                fov: Some(camera.fov),
                framed: false,
            },
            // A preset holds the camera as numbers, never the file's camera it came from.
            file_camera: None,
            environment: shading.environment,
            settings: RenderSettings {
                width: image.width,
                height: image.height,
                bounces: tracing.bounces,
                blend: tracing.blend,
                accel: tracing.accel,
                bvh: tracing.bvh,
                aov: image.aov,
                smooth: shading.smooth,
                textures: shading.textures,
                spp: shading.spp,
                adaptive: shading.adaptive,
                ao_samples: image.ao_samples,
                ao_radius: image.ao_radius,
            },
            accumulate: shading.accumulate,
        }
    }
}

// Each part's default is the default spec's, so a key left out means what the flag left
// out means.
impl Default for File {
    fn default() -> Self {
        File::from_spec(&SceneSpec::default())
    }
}

macro_rules! default_from_file {
    ($($part:ident: $ty:ty),+) => {
        $(impl Default for $ty {
            fn default() -> Self {
                File::default().$part
            }
        })+
    };
}
default_from_file!(model: ModelPart, image: ImagePart, tracing: TracingPart, shading: ShadingPart, light: LightPart, camera: CameraPart);

/// A preset that cannot be read: where (line from 1, dotted key) and what is wrong.
#[derive(Clone, Debug, PartialEq)]
pub struct PresetError {
    /// The line the problem is on, when the parser could tell.
    pub line: Option<usize>,
    /// The dotted key (`tracing.bounces`) whose value is wrong, when there is one.
    pub key: Option<String>,
    /// What is wrong, one sentence.
    pub message: String,
}

impl std::fmt::Display for PresetError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match (self.line, &self.key) {
            (Some(line), Some(key)) => write!(f, "line {line}, key '{key}': {}", self.message),
            (Some(line), None) => write!(f, "line {line}: {}", self.message),
            (None, Some(key)) => write!(f, "key '{key}': {}", self.message),
            (None, None) => write!(f, "{}", self.message),
        }
    }
}

impl std::error::Error for PresetError {}

/// A key the format does not know (ignored), with its line.
#[derive(Clone, Debug, PartialEq)]
pub struct UnknownKey {
    /// Dotted key, e.g. `image.colour`.
    pub key: String,
    /// Its line, from 1.
    pub line: usize,
}

/// The preset text of `spec`: what preset files hold and PNGs carry.
pub(crate) fn to_text(spec: &SceneSpec) -> String {
    let body = toml::to_string(&File::from_spec(spec)).expect("a preset always serializes");
    format!("{HEADER}{body}")
}

/// Read preset text: the spec (keys left out keep their defaults) and the keys that were
/// not understood.
pub fn from_text(text: &str) -> Result<(SceneSpec, Vec<UnknownKey>), PresetError> {
    let line_of = |offset: usize| text[..offset.min(text.len())].matches('\n').count() + 1;
    let doc = toml::de::DeTable::parse(text).map_err(|e| {
        let line = e.span().map(|s| line_of(s.start));
        // A syntax error: the key is the line's text before its `=`, if it has one.
        let key = line
            .and_then(|l| text.lines().nth(l - 1))
            .and_then(|l| l.split_once('='))
            .map(|(k, _)| k.trim().to_string())
            .filter(|k| !k.is_empty());
        PresetError { line, key, message: first_line(e.message()) }
    })?;
    let file: File = toml::from_str(text).map_err(|e| {
        let span = e.span();
        PresetError {
            line: span.as_ref().map(|s| line_of(s.start)),
            key: span.and_then(|s| key_at(doc.get_ref(), &s)),
            message: first_line(e.message()),
        }
    })?;
    let spec = file.into_spec();
    spec.validate().map_err(|message| {
        // The check that can fail here: an object's transform, or the camera's direction.
        let key = if message.starts_with("object ") { "object" } else { "camera.target" };
        PresetError {
            line: key_span(doc.get_ref(), key).map(|s| line_of(s.start)),
            key: Some(key.into()),
            message,
        }
    })?;
    // Every key the format has: the default file with the optional keys set.
    let mut all = File::default();
    all.model.crease_angle = Some(0.0);
    all.model.scatter = 1;
    all.shading.accumulate = 2;
    all.tracing.bvh = BvhLayout::Wide;
    all.object.push(ObjectPart::from_spec(&ObjectSpec {
        model: ModelSource::default(),
        placement: Placement::default(),
    }));
    let known = toml::Table::try_from(all).expect("a preset always serializes");
    let mut unknown = Vec::new();
    unknown_keys(doc.get_ref(), &known, "", &mut |key, span| {
        unknown.push(UnknownKey { key, line: line_of(span.start) })
    });
    Ok((spec, unknown))
}

fn first_line(message: &str) -> String {
    message.lines().next().unwrap_or("").trim().to_string()
}

fn join(prefix: &str, key: &str) -> String {
    if prefix.is_empty() {
        key.to_string()
    } else {
        format!("{prefix}.{key}")
    }
}

/// The dotted key whose value (or name) holds `span`'s start: the innermost one. Tables
/// are searched whatever their own span, which covers only a `[table]` header.
fn key_at(table: &toml::de::DeTable, span: &Range<usize>) -> Option<String> {
    for (key, value) in table.iter() {
        if let toml::de::DeValue::Table(t) = value.get_ref() {
            if let Some(inner) = key_at(t, span) {
                return Some(join(key.get_ref(), &inner));
            }
        }
        // `[[object]]` tables, numbered from 1 as the messages count objects.
        if let toml::de::DeValue::Array(items) = value.get_ref() {
            for (i, item) in items.iter().enumerate() {
                if let toml::de::DeValue::Table(t) = item.get_ref() {
                    if let Some(inner) = key_at(t, span) {
                        return Some(format!("{}[{}].{inner}", key.get_ref(), i + 1));
                    }
                }
            }
        }
        if key.span().contains(&span.start) || value.span().contains(&span.start) {
            return Some(key.get_ref().to_string());
        }
    }
    None
}

/// The span of dotted `key`'s value, if the document has it.
fn key_span(table: &toml::de::DeTable, key: &str) -> Option<Range<usize>> {
    let (head, rest) = key.split_once('.').map_or((key, None), |(h, r)| (h, Some(r)));
    let (_, value) = table.iter().find(|(k, _)| k.get_ref() == head)?;
    match (rest, value.get_ref()) {
        (None, _) => Some(value.span()),
        (Some(rest), toml::de::DeValue::Table(t)) => key_span(t, rest),
        _ => None,
    }
}

/// Call `found` for each key of `doc` that `known` (the serialized default) lacks.
fn unknown_keys(
    doc: &toml::de::DeTable,
    known: &toml::Table,
    prefix: &str,
    found: &mut impl FnMut(String, Range<usize>),
) {
    for (key, value) in doc.iter() {
        let name = key.get_ref();
        match (known.get(&**name), value.get_ref()) {
            (None, _) => found(join(prefix, name), key.span()),
            (Some(toml::Value::Table(k)), toml::de::DeValue::Table(t)) => {
                unknown_keys(t, k, &join(prefix, name), found)
            }
            // `[[object]]`: each table against the one known object.
            (Some(toml::Value::Array(k)), toml::de::DeValue::Array(items)) => {
                if let Some(toml::Value::Table(k)) = k.first() {
                    for (i, item) in items.iter().enumerate() {
                        if let toml::de::DeValue::Table(t) = item.get_ref() {
                            unknown_keys(t, k, &format!("{}[{}]", join(prefix, name), i + 1), found)
                        }
                    }
                }
            }
            _ => {}
        }
    }
}

impl SceneSpec {
    /// This spec as preset text (see [`crate::scene::preset`]): what preset files hold and the
    /// PNGs the program writes carry.
    pub fn to_preset_text(&self) -> String {
        to_text(self)
    }
}

/// A preset read from a file: the spec and warnings for keys that were ignored.
#[derive(Clone, Debug)]
pub struct Loaded {
    /// What the preset describes, keys left out at their defaults.
    pub spec: SceneSpec,
    /// One sentence per unknown key, naming the file, the key and the line.
    pub warnings: Vec<String>,
}

/// The largest TOML preset read.
const MAX_TEXT_BYTES: u64 = 1 << 20;
/// The largest PNG read for its preset (an 8192² screenshot with little compression).
const MAX_PNG_BYTES: u64 = 512 << 20;

/// Read a preset file: TOML, or a PNG this program wrote (its `meshtracer` chunk). The
/// error is one line naming the file (and the key and the line, for a bad value).
pub fn read(path: &Path) -> Result<Loaded, String> {
    let shown = crate::files::shown_path(path);
    // A PNG preset is a screenshot (big); a TOML preset is a page of text. Either way the
    // read is bounded, and only a regular file is opened (not a FIFO or /dev/zero).
    let bytes = crate::files::read_capped(path, "the preset", MAX_PNG_BYTES)?;
    let png = bytes.starts_with(b"\x89PNG\r\n\x1a\n");
    if !png && bytes.len() as u64 > MAX_TEXT_BYTES {
        return Err(format!("cannot read the preset {shown}: larger than 1 MiB (a preset is a page of text, or a PNG this program wrote)"));
    }
    let text = if png {
        match crate::files::image_files::png_settings(&bytes) {
            Ok(Some(text)) => text,
            Ok(None) => return Err(format!("preset {shown}: the PNG has no meshtracer settings (only PNGs this program wrote carry them)")),
            Err(e) => return Err(format!("preset {shown}: {e}")),
        }
    } else {
        String::from_utf8(bytes)
            .map_err(|_| format!("preset {shown}: neither a PNG nor a TOML text file"))?
    };
    let (mut spec, unknown) = from_text(&text).map_err(|e| format!("preset {shown}: {e}"))?;
    resolve_paths(&mut spec, path.parent().unwrap_or(Path::new("")));
    let warnings = unknown
        .iter()
        .map(|u| format!("preset {shown}: unknown key '{}' on line {} is ignored", u.key, u.line))
        .collect();
    Ok(Loaded { spec, warnings })
}

/// A relative model or environment path names a file beside the preset when one is there
/// (a folder of presets and models moves as a whole); otherwise it stays relative to the
/// working folder, as on the command line.
fn resolve_paths(spec: &mut SceneSpec, folder: &Path) {
    let beside = |p: &mut PathBuf| {
        let candidate = folder.join(&*p);
        if p.is_relative() && candidate.is_file() {
            *p = candidate;
        }
    };
    for model in
        std::iter::once(&mut spec.model).chain(spec.objects.iter_mut().map(|o| &mut o.model))
    {
        if let ModelSource::File(p) = model {
            beside(p);
        }
    }
    if let Some(EnvironmentSource::File(p)) = &mut spec.environment {
        beside(p);
    }
}

/// Paths as absolute as the file system allows, so a saved preset works from any folder.
fn absolute_paths(spec: &SceneSpec) -> SceneSpec {
    let mut spec = spec.clone();
    let absolute = |p: &mut PathBuf| *p = crate::files::canonical_or_given(p);
    for model in
        std::iter::once(&mut spec.model).chain(spec.objects.iter_mut().map(|o| &mut o.model))
    {
        if let ModelSource::File(p) = model {
            absolute(p);
        }
    }
    if let Some(EnvironmentSource::File(p)) = &mut spec.environment {
        absolute(p);
    }
    spec
}

/// Why a preset was not saved.
#[derive(Clone, Debug, PartialEq)]
pub enum SaveError {
    /// The file exists and overwriting was not asked for: ask the user first.
    Exists(PathBuf),
    /// Writing failed; one sentence naming the file.
    Io(String),
}

impl std::fmt::Display for SaveError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SaveError::Exists(p) => write!(f, "{} exists already", crate::files::shown_path(p)),
            SaveError::Io(e) => f.write_str(e),
        }
    }
}

/// Write `spec` as a preset to `path` (through `files::write_atomic`: a reader never sees
/// half a preset, and a failed write keeps the file that was there). An existing file is replaced only with `overwrite`.
pub fn save(spec: &SceneSpec, path: &Path, overwrite: bool) -> Result<(), SaveError> {
    if !overwrite && path.exists() {
        return Err(SaveError::Exists(path.to_path_buf()));
    }
    crate::files::write_bytes_atomic(path, to_text(&absolute_paths(spec)).as_bytes()).map_err(|e| {
        SaveError::Io(format!(
            "could not write the preset {}: {}",
            crate::files::shown_path(path),
            e.root_cause()
        ))
    })
}

#[cfg(test)]
#[path = "preset_tests.rs"]
mod tests;

//! The one way from a `--model` value to a mesh: [`load_model`] generates one of the paper's
//! models or a knot, or reads a file and parses it by its extension (OBJ, PLY, glTF 2.0),
//! then fits the mesh to the scene. The window's loader, `render`, `bench`, `bench --load`
//! and the tests all load through it.

use std::path::Path;

use super::obj::{load_obj_from_bytes, LoadOptions, LoadedObj, ObjError};
use super::paper::{prepare_model, ModelSource};
use super::{Mesh, Model};
use crate::files::read_regular_file_parallel;
use crate::progress::{Cancelled, Phase, Progress};

/// The model formats read, by extension, for messages and file dialogs.
pub const MODEL_EXTENSIONS: [&str; 4] = ["obj", "ply", "gltf", "glb"];

/// The model names `--model` and the panel accept, for messages.
pub const MODEL_NAMES: &str = "geosphere, torusknot, sphere, cylinder, torusknot:N (a generated knot of N triangles, e.g. torusknot:4M), or a path to an OBJ, PLY or glTF (.gltf/.glb) file";

/// Why a model could not be loaded; Display is one sentence, naming the file where there is one.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file could not be read or parsed (or its format is not one we read).
    #[error(transparent)]
    Model(#[from] ObjError),
    /// The `--model` value names neither a model nor a file ([`ModelSource::check_name`]).
    #[error("{0}")]
    Name(String),
    /// The load was cancelled (the window's Escape) before its next phase.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

/// A model file's format, chosen by its extension (any case).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Obj,
    Ply,
    Gltf,
}

/// Whether `path` names a glTF file (`.gltf` or `.glb`), whose nodes may place many meshes.
pub(super) fn is_gltf(path: &Path) -> bool {
    matches!(Format::of(path), Ok(Format::Gltf))
}

impl Format {
    /// The format of `path`, or the one-sentence error naming it.
    fn of(path: &Path) -> Result<Self, ObjError> {
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("obj") => Ok(Format::Obj),
            Some("ply") => Ok(Format::Ply),
            Some("gltf" | "glb") => Ok(Format::Gltf),
            _ => Err(ObjError::Invalid {
                name: crate::files::shown_path(path),
                reason: "unknown model format; expected an OBJ (.obj), PLY (.ply) or glTF 2.0 (.gltf, .glb) file".to_owned(),
            }),
        }
    }

    /// Parse the bytes read from `path`; `options` apply to OBJ files. A file's .mtl,
    /// buffers and textures are found beside it (`parent()` of a bare file name is "",
    /// which joins to paths relative to the working directory: where the file was found).
    fn parse(
        self,
        bytes: Vec<u8>,
        path: &Path,
        options: &LoadOptions,
    ) -> Result<LoadedModel, ObjError> {
        let name = crate::files::shown_path(path);
        Ok(match self {
            Format::Obj => load_obj_from_bytes(bytes, &name, path.parent(), options)?.into(),
            Format::Ply => super::ply::load_ply_from_bytes(&bytes, &name)?.into(),
            Format::Gltf => {
                // A glTF file is a model of parts: its meshes stored once, placed by its nodes.
                let loaded = super::gltf::load_gltf_from_bytes(&bytes, &name, path.parent())?;
                LoadedModel { model: loaded.model, warnings: loaded.warnings }
            }
        })
    }
}

/// A model as [`load_model`] gives it: fitted to the scene, with the loader's warnings.
#[derive(Clone, Debug)]
pub struct LoadedModel {
    pub model: Model,
    /// What the loader skipped or could not read (a missing .mtl, a texture...).
    pub warnings: Vec<String>,
}

impl From<LoadedObj> for LoadedModel {
    fn from(loaded: LoadedObj) -> Self {
        LoadedModel { model: loaded.mesh.into(), warnings: loaded.warnings }
    }
}

impl From<LoadedModel> for LoadedObj {
    /// The model flattened into one mesh ([`LoadedModel::into_mesh`]), warnings kept.
    fn from(loaded: LoadedModel) -> Self {
        let warnings = loaded.warnings.clone();
        LoadedObj { mesh: loaded.into_mesh(), warnings }
    }
}

impl LoadedModel {
    /// The model as one mesh ([`Model::flatten`]): what an OBJ or PLY file gives as it is.
    pub fn into_mesh(self) -> Mesh {
        let mut model = self.model;
        if model.is_single_mesh() {
            return model.meshes.swap_remove(0);
        }
        model.flatten()
    }
}

/// Load (or generate) the model `source` names, fitted to the scene's size and given the
/// model's look where the file leaves materials at their defaults ([`prepare_model`]);
/// `options` apply to OBJ files. With a `progress`, the read and the parse (a generated
/// model's making) are reported as phases, and a cancelled load stops before the next.
/// The loader's warnings come back with the mesh.
pub fn load_model(
    source: &ModelSource,
    options: &LoadOptions,
    progress: Option<&Progress>,
) -> Result<LoadedModel, LoadError> {
    let begin = |phase| progress.map_or(Ok(()), |p| p.begin(phase));
    source.check_name().map_err(LoadError::Name)?;
    let mut loaded: LoadedModel = match source {
        ModelSource::Paper(m) => {
            begin(Phase::Parse)?;
            LoadedModel { model: m.mesh().into(), warnings: Vec::new() }
        }
        ModelSource::Generated(n) => {
            begin(Phase::Parse)?;
            let mesh = super::primitives::large_torus_knot(*n);
            LoadedModel { model: mesh.into(), warnings: Vec::new() }
        }
        ModelSource::File(path) => {
            // An unknown extension is refused before the file is read.
            let format = Format::of(path)?;
            begin(Phase::Read)?;
            let bytes = read_regular_file_parallel(path)
                .map_err(|source| ObjError::Io { path: path.to_owned(), source })?;
            begin(Phase::Parse)?;
            format.parse(bytes, path, options)?
        }
    };
    if loaded.model.triangle_count() == 0 {
        return Err(ObjError::NoFaces { name: source.label() }.into());
    }
    prepare_model(&mut loaded.model);
    Ok(loaded)
}

impl ModelSource {
    /// A file that does not exist and does not look like a path was probably meant as a
    /// model name: say which names there are, instead of "No such file".
    pub fn check_name(&self) -> Result<(), String> {
        let ModelSource::File(path) = self else { return Ok(()) };
        let text = path.to_string_lossy();
        let looks_like_path = text.contains(['/', '\\']) || path.extension().is_some();
        if path.exists() || looks_like_path {
            return Ok(());
        }
        let why = if text.starts_with("torusknot:") {
            "is not a triangle count from 1 to 100M"
        } else {
            "is no model name and no file"
        };
        Err(format!("'{text}' {why}; expected {MODEL_NAMES}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::primitives::PaperModel;

    #[test]
    fn misspelt_model_names_list_the_valid_ones() {
        for typed in ["torusknot:abc", "geosphre", "torusknot:0"] {
            let err = ModelSource::parse(typed).check_name().unwrap_err();
            assert!(err.contains(typed) && err.contains("geosphere, torusknot"), "{err}");
            let err = load_model(&ModelSource::parse(typed), &LoadOptions::default(), None)
                .unwrap_err()
                .to_string();
            assert!(err.contains(typed), "the load says so too: {err}");
        }
        assert!(ModelSource::parse("torusknot:1M").check_name().is_ok());
        assert!(
            ModelSource::parse("missing/model.obj").check_name().is_ok(),
            "a path gets the file system's message"
        );
    }

    #[test]
    fn formats_are_chosen_by_extension_in_any_case() {
        for (name, format) in [
            ("a.obj", Format::Obj),
            ("b.PLY", Format::Ply),
            ("c.gltf", Format::Gltf),
            ("d.Glb", Format::Gltf),
        ] {
            assert_eq!(Format::of(Path::new(name)).unwrap(), format, "{name}");
        }
        for name in ["e.stl", "noextension", "f.obj.gz"] {
            let e = Format::of(Path::new(name)).unwrap_err().to_string();
            assert!(e.contains(name) && e.contains("unknown model format"), "{e}");
        }
    }

    #[test]
    fn a_generated_model_is_fitted_and_reports_one_phase() {
        let progress = Progress::default();
        let loaded =
            load_model(&ModelSource::Generated(1000), &LoadOptions::default(), Some(&progress))
                .unwrap();
        let b = loaded.model.bounds();
        let half = ((b.max - b.min) * 0.5).max_element();
        assert!((half - super::super::paper::MODEL_RADIUS).abs() < 1e-5, "{half}");
        let phases: Vec<Phase> = progress.snapshot().phases.iter().map(|p| p.phase).collect();
        assert_eq!(phases, [Phase::Parse]);

        let cancelled = Progress::default();
        cancelled.cancel();
        let source = ModelSource::Paper(PaperModel::Sphere);
        let e = load_model(&source, &LoadOptions::default(), Some(&cancelled)).unwrap_err();
        assert!(matches!(e, LoadError::Cancelled(_)), "{e}");
    }

    #[test]
    fn a_missing_file_is_one_sentence_naming_it() {
        let source = ModelSource::File("/nonexistent/model.ply".into());
        let e = load_model(&source, &LoadOptions::default(), None).unwrap_err().to_string();
        assert!(e.contains("/nonexistent/model.ply") && !e.contains('\n'), "{e}");
    }
}

//! Material libraries: the `mtllib` loader handed to tobj (files found next to the OBJ,
//! failures turned into warnings), the clean-up that makes .mtl colour lines safe for
//! tobj, and the conversion of tobj's materials into ours with `map_Kd` resolved.

use std::cell::RefCell;
use std::path::{Path, PathBuf};

use glam::Vec3;

use super::line_feeder::LineFeeder;
use super::{quote, read_regular_file, warn};
use crate::scene::Material;

/// The `mtllib` loader handed to tobj: reads libraries relative to the OBJ's folder and
/// turns every failure into a warning.
pub(super) struct MaterialLibraries<'a> {
    pub(super) base_dir: Option<&'a Path>,
    pub(super) obj_name: &'a str,
    /// For each library that loaded: its path and how many materials it added. tobj
    /// appends libraries in call order, so this maps a material back to its folder.
    pub(super) loaded: RefCell<Vec<(PathBuf, usize)>>,
    pub(super) warnings: RefCell<Vec<String>>,
}

impl MaterialLibraries<'_> {
    fn warn(&self, message: String) {
        warn(&mut self.warnings.borrow_mut(), message);
    }

    /// tobj's callback for `mtllib`: the library's materials, or an error once warned about.
    pub(super) fn load(&self, mtllib: &Path) -> tobj::MTLLoadResult {
        let Some(base) = self.base_dir else {
            self.warn(format!(
                "{}: `mtllib {}` ignored (the OBJ was not loaded from a folder); using the default material",
                self.obj_name,
                mtllib.display()
            ));
            return Err(tobj::LoadError::OpenFileFailed);
        };
        // tobj passes the whole rest of the line, which may name several libraries
        // (`mtllib a.mtl b.mtl`) or one with spaces in its name.
        let spelled = mtllib.to_string_lossy();
        if spelled.trim().is_empty() {
            self.warn(format!("{}: `mtllib` names no file; using the default material", self.obj_name));
            return Err(tobj::LoadError::OpenFileFailed);
        }
        let parts: Vec<&str> = if find_file(base, &spelled).is_some() || !spelled.contains(char::is_whitespace) {
            vec![spelled.as_ref()]
        } else {
            spelled.split_whitespace().collect()
        };
        let mut merged: Option<(Vec<tobj::Material>, _)> = None;
        for part in parts {
            let Ok((mats, map)) = self.load_one(base, part) else { continue };
            match &mut merged {
                None => merged = Some((mats, map)),
                Some((all, all_map)) => {
                    let offset = all.len();
                    all_map.extend(map.into_iter().map(|(name, i)| (name, i + offset)));
                    all.extend(mats);
                }
            }
        }
        merged.ok_or(tobj::LoadError::OpenFileFailed)
    }

    fn load_one(&self, base: &Path, spelled: &str) -> tobj::MTLLoadResult {
        let path = find_file(base, spelled).unwrap_or_else(|| base.join(spelled));
        let bytes = match read_regular_file(&path) {
            Ok(b) => b,
            Err(e) => {
                self.warn(format!(
                    "{}: material library {} cannot be read ({e}); using the default material",
                    self.obj_name,
                    path.display()
                ));
                return Err(tobj::LoadError::OpenFileFailed);
            }
        };
        // Material names and texture paths are often Latin-1: keep going rather than fail.
        let text = String::from_utf8_lossy(&bytes);
        let mtl_name = path.display().to_string();
        let text = sanitize_mtl(&text, &mtl_name, &mut self.warnings.borrow_mut());
        let mut feeder = LineFeeder::new(&text, &mtl_name, false);
        match tobj::load_mtl_buf(&mut feeder) {
            Ok((mats, map)) => {
                self.loaded.borrow_mut().push((path, mats.len()));
                Ok((mats, map))
            }
            Err(e) => {
                self.warn(format!(
                    "{mtl_name} line {}: {e} in {}; the library's materials are ignored",
                    feeder.line,
                    quote(feeder.current_line)
                ));
                Err(e)
            }
        }
    }
}

/// `dir/spelled` if it is a file, also reading `\` as a path separator (files exported on Windows).
fn find_file(dir: &Path, spelled: &str) -> Option<PathBuf> {
    let direct = dir.join(spelled);
    if direct.is_file() {
        return Some(direct);
    }
    let slashed = dir.join(spelled.replace('\\', "/"));
    slashed.is_file().then_some(slashed)
}

/// Make colour lines safe for tobj, which panics on a `Kd` with fewer than three values
/// and rejects the whole library for `Kd spectral ...`. `Kd r` means grey (the MTL spec
/// repeats r); other malformed colour lines are blanked with a warning. Line numbers stay.
fn sanitize_mtl(text: &str, mtl_name: &str, warnings: &mut Vec<String>) -> String {
    let mut out = String::with_capacity(text.len() + 64);
    for (i, line) in text.split_inclusive('\n').enumerate() {
        let mut words = line.split_whitespace();
        let keyword = words.next().unwrap_or("");
        if matches!(keyword, "Ka" | "Kd" | "Ks" | "Ke") {
            let values: Vec<&str> = words.collect();
            let numeric = |n: usize| values.len() >= n && values[..n].iter().all(|v| v.parse::<f32>().is_ok());
            if numeric(3) {
                out.push_str(line);
            } else if values.len() == 1 && numeric(1) {
                let r = values[0];
                out.push_str(&format!("{keyword} {r} {r} {r}\n"));
            } else {
                warn(warnings, format!("{mtl_name} line {}: {} is not an RGB colour; ignored", i + 1, quote(line)));
                out.push('\n');
            }
        } else {
            out.push_str(line);
        }
    }
    out
}

/// Our materials from tobj's, with `map_Kd` resolved next to the library that named it.
pub(super) fn convert_materials(mats: &[tobj::Material], loaded: &[(PathBuf, usize)], warnings: &mut Vec<String>) -> Vec<Material> {
    let mut libraries = loaded.iter().flat_map(|(path, count)| std::iter::repeat_n(path.as_path(), *count));
    mats.iter().map(|m| convert_material(m, libraries.next(), warnings)).collect()
}

fn convert_material(m: &tobj::Material, library: Option<&Path>, warnings: &mut Vec<String>) -> Material {
    let default = Material::default();
    let color = |c: Option<[f32; 3]>, fallback: Vec3| c.map(Vec3::from).filter(|v| v.is_finite()).unwrap_or(fallback);
    let mut out = Material {
        name: m.name.clone(),
        diffuse: color(m.diffuse, default.diffuse),
        specular: color(m.specular, default.specular),
        shininess: m.shininess.filter(|s| s.is_finite() && *s >= 0.0).unwrap_or(default.shininess),
        ..default
    };
    if let Some(raw) = &m.diffuse_texture {
        let dir = library.and_then(Path::parent).unwrap_or(Path::new(""));
        out.diffuse_texture = texture_path(dir, raw);
        if out.diffuse_texture.is_none() {
            let library = library.map_or_else(|| "a material library".to_owned(), |p| p.display().to_string());
            warn(warnings, format!("{library}: texture `{raw}` of material {} not found; the material keeps its plain colour", m.name));
        }
        // Exporters write `Kd 0 0 0` when the map supplies the colour (all of Sponza does).
        // Taken literally that is black whatever the renderer does with textures: white
        // lets `texture * diffuse` show the texture, and grey stands in for a missing one.
        if out.diffuse == Vec3::ZERO {
            out.diffuse = if out.diffuse_texture.is_some() { Vec3::ONE } else { Material::default().diffuse };
        }
    }
    out
}

/// The file a `map_Kd` value names. Options come before the name
/// (`map_Kd -s 1 1 1 -bm 0.5 wall.png`), but a name may also contain spaces.
fn texture_path(dir: &Path, raw: &str) -> Option<PathBuf> {
    let raw = raw.trim();
    find_file(dir, raw).or_else(|| raw.split_whitespace().last().and_then(|file| find_file(dir, file)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mtl_colours_are_made_safe_for_tobj() {
        let mut warnings = Vec::new();
        let text = sanitize_mtl("newmtl a\nKd 0.5\nKs 1 2\nKa spectral x.rfl\nKe 1 2 3\n", "m.mtl", &mut warnings);
        assert_eq!(text, "newmtl a\nKd 0.5 0.5 0.5\n\n\nKe 1 2 3\n");
        assert_eq!(warnings.len(), 2);
        assert!(warnings[0].contains("m.mtl line 3"), "{}", warnings[0]);
    }
}

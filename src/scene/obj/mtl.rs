//! Material libraries: the `mtllib` loader handed to tobj (files found next to the OBJ,
//! failures turned into warnings), the clean-up that makes .mtl colour lines safe for
//! tobj, and the conversion of tobj's materials into ours with `map_Kd` resolved.

use std::cell::RefCell;
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use super::line_feeder::LineFeeder;
use super::{quote, quote_name, warn};
use crate::files::read_regular_file;
use crate::scene::{Material, TextureTransform};

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
                quote_name(&mtllib.to_string_lossy())
            ));
            return Err(tobj::LoadError::OpenFileFailed);
        };
        // tobj passes the whole rest of the line, which may name several libraries
        // (`mtllib a.mtl b.mtl`) or one with spaces in its name.
        let spelled = mtllib.to_string_lossy();
        if spelled.trim().is_empty() {
            self.warn(format!(
                "{}: `mtllib` names no file; using the default material",
                self.obj_name
            ));
            return Err(tobj::LoadError::OpenFileFailed);
        }
        // A name with spaces that exists as written wins; otherwise the names are separated
        // by whitespace, and `\ ` is a space inside a name (`mtllib a.mtl my\ file.mtl`).
        let parts: Vec<String> = if find_file(base, &spelled).is_some() {
            vec![spelled.clone().into_owned()]
        } else {
            split_escaped(&spelled)
        };
        let mut merged: Option<(Vec<tobj::Material>, _)> = None;
        for part in &parts {
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
                    quote_name(&path.to_string_lossy())
                ));
                return Err(tobj::LoadError::OpenFileFailed);
            }
        };
        // Material names and texture paths are often Latin-1: keep going rather than fail.
        let text = String::from_utf8_lossy(&bytes);
        let mtl_name = quote_name(&path.display().to_string());
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

/// Words separated by whitespace, where a backslash before a whitespace character makes
/// it part of the word (`my\ file.mtl` is `my file.mtl`). Other backslashes stay: they
/// are Windows path separators.
fn split_escaped(text: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut word = String::new();
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '\\' if chars.peek().is_some_and(|n| n.is_whitespace()) => word.extend(chars.next()),
            c if c.is_whitespace() => {
                if !word.is_empty() {
                    words.push(std::mem::take(&mut word));
                }
            }
            c => word.push(c),
        }
    }
    if !word.is_empty() {
        words.push(word);
    }
    words
}

/// `dir/spelled` if it exists and is not a folder, also reading `\` as a path separator
/// (files exported on Windows). A FIFO or a device is found, so that its reader says it is
/// not a regular file rather than this saying "not found".
fn find_file(dir: &Path, spelled: &str) -> Option<PathBuf> {
    let found = |p: &Path| p.exists() && !p.is_dir();
    let direct = dir.join(spelled);
    if found(&direct) {
        return Some(direct);
    }
    let slashed = dir.join(spelled.replace('\\', "/"));
    found(&slashed).then_some(slashed)
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
            let numeric = |n: usize| {
                values.len() >= n && values[..n].iter().all(|v| v.parse::<f32>().is_ok())
            };
            if numeric(3) {
                out.push_str(line);
            } else if values.len() == 1 && numeric(1) {
                let r = values[0];
                out.push_str(&format!("{keyword} {r} {r} {r}\n"));
            } else {
                warn(
                    warnings,
                    format!(
                        "{mtl_name} line {}: {} is not an RGB colour; ignored",
                        i + 1,
                        quote(line)
                    ),
                );
                out.push('\n');
            }
        } else {
            out.push_str(line);
        }
    }
    out
}

/// Our materials from tobj's, with `map_Kd` resolved next to the library that named it.
pub(super) fn convert_materials(
    mats: &[tobj::Material],
    loaded: &[(PathBuf, usize)],
    warnings: &mut Vec<String>,
) -> Vec<Material> {
    let mut libraries =
        loaded.iter().flat_map(|(path, count)| std::iter::repeat_n(path.as_path(), *count));
    mats.iter().map(|m| convert_material(m, libraries.next(), warnings)).collect()
}

fn convert_material(
    m: &tobj::Material,
    library: Option<&Path>,
    warnings: &mut Vec<String>,
) -> Material {
    let default = Material::default();
    let color = |c: Option<[f32; 3]>, fallback: Vec3| {
        c.map(Vec3::from).filter(|v| v.is_finite()).unwrap_or(fallback)
    };
    let mut out = Material {
        name: m.name.clone(),
        diffuse: color(m.diffuse, default.diffuse),
        specular: color(m.specular, default.specular),
        shininess: m.shininess.filter(|s| s.is_finite() && *s >= 0.0).unwrap_or(default.shininess),
        ..default
    };
    if let Some(raw) = &m.diffuse_texture {
        let dir = library.and_then(Path::parent).unwrap_or(Path::new(""));
        let library = library.map_or_else(
            || "a material library".to_owned(),
            |p| quote_name(&p.display().to_string()),
        );
        let map = texture_map(dir, raw);
        out.diffuse_texture = map.path.map(crate::scene::TextureSource::File);
        out.texture_transform = map.transform;
        if !map.ignored.is_empty() {
            let options = map.ignored.join(", ");
            let plural = if map.ignored.len() == 1 { "option" } else { "options" };
            warn(
                warnings,
                format!(
                    "{library}: material {}: `map_Kd` {plural} {} not supported; ignored",
                    quote_name(&m.name),
                    quote_name(&options)
                ),
            );
        }
        if out.diffuse_texture.is_none() {
            warn(warnings, format!("{library}: texture `{}` of material {} not found; the material keeps its plain colour", quote_name(map.file), quote_name(&m.name)));
        }
        // Exporters write `Kd 0 0 0` when the map supplies the colour (all of Sponza does).
        // Taken literally that is black whatever the renderer does with textures: white
        // lets `texture * diffuse` show the texture, and grey stands in for a missing one.
        if out.diffuse == Vec3::ZERO {
            out.diffuse =
                if out.diffuse_texture.is_some() { Vec3::ONE } else { Material::default().diffuse };
        }
    }
    out
}

/// A `map_*` statement's value: its options, then the file name.
#[derive(Clone, Debug, PartialEq)]
struct TextureMap<'a> {
    /// `-o`, `-s` and `-clamp`.
    transform: TextureTransform,
    /// The other options, by name, in order of appearance (each once).
    ignored: Vec<&'a str>,
    /// The file name as written after the options (spaces allowed).
    file: &'a str,
    /// The file found, if any.
    path: Option<PathBuf>,
}

/// How many arguments an MTL texture option takes.
enum OptionArgs {
    /// `-o`, `-s`, `-t`: one to three numbers.
    UpToThreeNumbers,
    /// This many numbers (`-mm` 2; `-bm`, `-boost`, `-texres` 1).
    Numbers(usize),
    /// One word (`on`/`off`, a channel letter, a colour space, a map type).
    Word,
}

fn option_args(name: &str) -> Option<OptionArgs> {
    Some(match name.to_ascii_lowercase().as_str() {
        "-o" | "-s" | "-t" => OptionArgs::UpToThreeNumbers,
        "-mm" => OptionArgs::Numbers(2),
        "-bm" | "-boost" | "-texres" => OptionArgs::Numbers(1),
        "-clamp" | "-blendu" | "-blendv" | "-cc" | "-imfchan" | "-colorspace" | "-type" => {
            OptionArgs::Word
        }
        _ => return None,
    })
}

/// Read the options at the front of a `map_Kd` value (`-o 0.5 0 -clamp on wall.png`) and
/// find the file that the rest names, next to the library. A value that names a file as
/// a whole (options or not) is taken as that file; an option's arguments never take the
/// last word, which is always part of the name.
fn texture_map<'a>(dir: &Path, raw: &'a str) -> TextureMap<'a> {
    let raw = raw.trim();
    let mut map = TextureMap {
        transform: TextureTransform::default(),
        ignored: Vec::new(),
        file: raw,
        path: None,
    };
    if let Some(path) = find_file(dir, raw) {
        map.path = Some(path);
        return map;
    }
    // Words with their byte offsets, so that the name keeps its inner spacing.
    let words: Vec<(usize, &str)> =
        raw.split_whitespace().map(|w| (w.as_ptr() as usize - raw.as_ptr() as usize, w)).collect();
    let number = |w: &str| w.parse::<f32>().ok().filter(|v| v.is_finite());
    let mut i = 0;
    while i + 1 < words.len() {
        let name = words[i].1;
        if !name.starts_with('-') || name.len() < 2 {
            break;
        }
        i += 1;
        // Arguments may not take the last word: that is the file name.
        let available = words.len() - 1 - i;
        let mut values = Vec::new();
        let mut word = None;
        match option_args(name) {
            Some(OptionArgs::UpToThreeNumbers) => {
                while values.len() < 3.min(available) {
                    let Some(v) = number(words[i].1) else { break };
                    values.push(v);
                    i += 1;
                }
            }
            Some(OptionArgs::Numbers(n)) => {
                while values.len() < n.min(available) {
                    let Some(v) = number(words[i].1) else { break };
                    values.push(v);
                    i += 1;
                }
            }
            Some(OptionArgs::Word) if available > 0 => {
                word = Some(words[i].1);
                i += 1;
            }
            Some(OptionArgs::Word) | None => {}
        }
        match name.to_ascii_lowercase().as_str() {
            "-s" if !values.is_empty() => {
                map.transform.scale = Vec2::new(values[0], values.get(1).copied().unwrap_or(1.0));
            }
            "-o" if !values.is_empty() => {
                map.transform.offset = Vec2::new(values[0], values.get(1).copied().unwrap_or(0.0));
            }
            "-clamp" if word.is_some_and(|w| w.eq_ignore_ascii_case("on")) => {
                map.transform.clamp = true
            }
            "-clamp" if word.is_some_and(|w| w.eq_ignore_ascii_case("off")) => {
                map.transform.clamp = false
            }
            _ => {
                if !map.ignored.contains(&name) {
                    map.ignored.push(name);
                }
            }
        }
    }
    map.file = words.get(i).map_or("", |&(at, _)| raw[at..].trim());
    // As written; with `\ ` read as a space; else the last word (after an option this
    // reader does not know, whose arguments joined the name).
    map.path = find_file(dir, map.file)
        .or_else(|| {
            map.file
                .contains("\\ ")
                .then(|| find_file(dir, &map.file.replace("\\ ", " ")))
                .flatten()
        })
        .or_else(|| map.file.split_whitespace().last().and_then(|file| find_file(dir, file)));
    map
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mtl_colours_are_made_safe_for_tobj() {
        let mut warnings = Vec::new();
        let text = sanitize_mtl(
            "newmtl a\nKd 0.5\nKs 1 2\nKa spectral x.rfl\nKe 1 2 3\n",
            "m.mtl",
            &mut warnings,
        );
        assert_eq!(text, "newmtl a\nKd 0.5 0.5 0.5\n\n\nKe 1 2 3\n");
        assert_eq!(warnings.len(), 2);
        assert!(warnings[0].contains("m.mtl line 3"), "{}", warnings[0]);
    }

    #[test]
    fn texture_options_come_before_the_file_name() {
        let nowhere = Path::new("/nonexistent-meshtracer-dir");
        let read = |raw: &'static str| texture_map(nowhere, raw);

        let m = read("-o 0.1 diffuse.jpg");
        assert_eq!(
            (m.file, m.transform.offset, m.transform.scale),
            ("diffuse.jpg", Vec2::new(0.1, 0.0), Vec2::ONE)
        );
        assert!(m.ignored.is_empty() && !m.transform.clamp && m.path.is_none());

        let m = read("-colorspace sRGB -o 0.1 diffuse.jpg");
        assert_eq!(
            (m.file, m.ignored.as_slice(), m.transform.offset),
            ("diffuse.jpg", ["-colorspace"].as_slice(), Vec2::new(0.1, 0.0))
        );

        let m = read("-texres 512 input.jpg");
        assert_eq!((m.file, m.ignored.as_slice()), ("input.jpg", ["-texres"].as_slice()));

        // u, v and w; w is read and dropped. The name keeps its inner spaces.
        let m = read("-s 2 3 1  -o 0.5 0.25 0 -clamp on  my  wall.png ");
        assert_eq!(
            m.transform,
            TextureTransform {
                scale: Vec2::new(2.0, 3.0),
                offset: Vec2::new(0.5, 0.25),
                clamp: true
            }
        );
        assert_eq!(m.file, "my  wall.png");

        // Every other option of the MTL format, each with its arguments, ignored once.
        let m = read("-bm 0.5 -mm 0 1 -blendu off -blendv off -cc on -imfchan r -boost 2 -t 0.1 0.1 -bm 2 -type sphere x.png");
        assert_eq!(
            m.ignored,
            ["-bm", "-mm", "-blendu", "-blendv", "-cc", "-imfchan", "-boost", "-t", "-type"]
        );
        assert_eq!((m.file, m.transform), ("x.png", TextureTransform::default()));

        // Arguments never take the last word; -o with u alone keeps v = 0, -s keeps v = 1.
        let m = read("-o 1 2");
        assert_eq!((m.file, m.transform.offset), ("2", Vec2::new(1.0, 0.0)));
        let m = read("-s 0.5 t.png");
        assert_eq!(m.transform.scale, Vec2::new(0.5, 1.0));
        assert_eq!(read("-clamp").file, "-clamp");
        assert_eq!(read("plain name.png").file, "plain name.png");
        // An option this reader does not know is ignored, named; its arguments join the name.
        let m = read("-halo 3 t.png");
        assert_eq!((m.file, m.ignored.as_slice()), ("3 t.png", ["-halo"].as_slice()));
    }

    #[test]
    fn library_names_split_at_unescaped_spaces() {
        assert_eq!(split_escaped("a.mtl  my\\ file.mtl\tb.mtl"), ["a.mtl", "my file.mtl", "b.mtl"]);
        assert_eq!(split_escaped("dir\\sub.mtl"), ["dir\\sub.mtl"]);
        assert_eq!(split_escaped("  "), Vec::<String>::new());
    }
}

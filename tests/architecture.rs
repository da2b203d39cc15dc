//! The house rules of ARCHITECTURE.md, checked on the source: every import in `src/` runs
//! down the layers (a module imports only the modules listed before it in [`LAYERS`] or
//! its own), and no two files import each other, directly or round a circle.
//!
//! Imports are read from the text: `use` items and `crate::`/`super::`/`self::` paths in
//! code, outside comments and `#[cfg(test)]` items (a test may reach anywhere).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The top-level modules from the bottom up.
const LAYERS: &[&str] = &[
    "contract",
    "geometry",
    "memory",
    "progress",
    "render_settings",
    "files",
    "bvh",
    "scene",
    "tracer",
    "gpu",
    "bench",
    "app",
    "cli",
];

type Module = Vec<String>;

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The module a file defines: `src/a/b.rs` and `src/a/b/mod.rs` are `a::b`.
fn module_of(src: &Path, file: &Path) -> Module {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Module = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
    if matches!(parts.last().map(String::as_str), Some("mod" | "lib" | "main")) {
        parts.pop();
    }
    parts
}

/// The text without comments, string literals and `#[cfg(test)]` items.
fn code_of(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if text[i..].starts_with("//") {
            i += text[i..].find('\n').unwrap_or(text.len() - i);
        } else if text[i..].starts_with("/*") {
            i += text[i..].find("*/").map_or(text.len() - i, |j| j + 2);
        } else if text[i..].starts_with("r#\"") {
            i += text[i + 3..].find("\"#").map_or(text.len() - i, |j| j + 5);
            out.push_str("\"\"");
        } else if b[i] == b'\'' && i + 2 < b.len() && (b[i + 2] == b'\'' || b[i + 1] == b'\\') {
            // A char literal ('"', '\n'), not a lifetime.
            i = if b[i + 1] == b'\\' {
                text[i + 3..].find('\'').map_or(text.len(), |j| i + 3 + j + 1)
            } else {
                i + 3
            };
            out.push_str("' '");
        } else if b[i] == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += if b[i] == b'\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if text[i..].starts_with("#[cfg(test)]") {
            // Skip the item: up to its `;` or the end of its `{ ... }`.
            let mut depth = 0;
            while i < b.len() {
                match b[i] {
                    b';' if depth == 0 => break,
                    b'{' => depth += 1,
                    b'}' => {
                        depth -= 1;
                        if depth == 0 {
                            break;
                        }
                    }
                    _ => {}
                }
                i += 1;
            }
            i += 1;
        } else {
            let c = text[i..].chars().next().unwrap();
            out.push(c);
            i += c.len_utf8();
        }
    }
    out
}

/// Every path a `use` tree names, braces expanded: `a::{b, c::d}` is `a::b`, `a::c::d`.
fn expand(tree: &str) -> Vec<String> {
    let tree = tree.trim();
    let Some(open) = tree.find('{') else {
        return vec![tree.split(" as ").next().unwrap().trim().to_string()];
    };
    let (prefix, inner) = (&tree[..open], &tree[open + 1..tree.rfind('}').unwrap()]);
    let (mut parts, mut depth, mut start) = (Vec::new(), 0, 0);
    for (i, c) in inner.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&inner[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    parts.push(&inner[start..]);
    parts
        .iter()
        .filter(|p| !p.trim().is_empty())
        .flat_map(|p| expand(p))
        .map(|p| format!("{prefix}{p}"))
        .collect()
}

/// The paths one file's code names that start at `crate`, `super` or `self`.
fn named_paths(code: &str) -> Vec<String> {
    let mut paths = Vec::new();
    for stmt in code.split(';') {
        let t = stmt.trim_start();
        let t = t
            .strip_prefix("pub(crate) ")
            .or_else(|| t.strip_prefix("pub(super) "))
            .or_else(|| t.strip_prefix("pub "))
            .unwrap_or(t);
        if let Some(tree) = t.strip_prefix("use ") {
            paths.extend(expand(tree));
        }
    }
    let bytes = code.as_bytes();
    for start in ["crate::", "super::"] {
        for (i, _) in code.match_indices(start) {
            let before = if i == 0 { b' ' } else { bytes[i - 1] };
            if before.is_ascii_alphanumeric() || before == b'_' || before == b':' {
                continue;
            }
            let end = code[i..]
                .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                .map_or(code.len(), |j| i + j);
            paths.push(code[i..end].to_string());
        }
    }
    paths
}

/// The module file a path lands in, from the file `from` (longest known prefix).
fn resolve(from: &Module, path: &str, known: &BTreeSet<Module>) -> Option<Module> {
    let mut segs = path.split("::").filter(|s| !s.is_empty()).peekable();
    let mut full: Module = match *segs.peek()? {
        "crate" => {
            segs.next();
            Vec::new()
        }
        "super" | "self" => {
            let mut base = from.clone();
            while let Some(&s) = segs.peek() {
                match s {
                    "super" => {
                        base.pop();
                    }
                    "self" => {}
                    _ => break,
                }
                segs.next();
            }
            base
        }
        _ => return None,
    };
    full.extend(segs.map(String::from));
    (0..=full.len()).rev().map(|n| full[..n].to_vec()).find(|m| known.contains(m))
}

/// Every file's imports of other files of `src/`.
fn import_graph() -> BTreeMap<Module, BTreeSet<Module>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let modules: BTreeMap<Module, PathBuf> =
        files.iter().map(|f| (module_of(&src, f), f.clone())).collect();
    let known: BTreeSet<Module> = modules.keys().cloned().collect();
    modules
        .iter()
        .map(|(m, f)| {
            let code = code_of(&std::fs::read_to_string(f).unwrap());
            let targets = named_paths(&code)
                .iter()
                .filter_map(|p| resolve(m, p, &known))
                .filter(|t| t != m)
                .collect();
            (m.clone(), targets)
        })
        .collect()
}

fn name(m: &Module) -> String {
    if m.is_empty() {
        "crate".into()
    } else {
        m.join("::")
    }
}

#[test]
fn imports_run_down_the_layers() {
    let layer = |m: &Module| m.first().and_then(|top| LAYERS.iter().position(|l| l == top));
    let mut up = Vec::new();
    for (from, targets) in import_graph() {
        let Some(lf) = layer(&from) else { continue };
        for to in targets {
            if layer(&to).is_some_and(|lt| lt > lf) {
                up.push(format!("{} -> {}", name(&from), name(&to)));
            }
        }
    }
    assert!(up.is_empty(), "imports up the layers (ARCHITECTURE.md):\n{}", up.join("\n"));
}

#[test]
fn every_top_level_module_has_a_layer() {
    let graph = import_graph();
    let tops: BTreeSet<&str> = graph.keys().filter_map(|m| m.first().map(String::as_str)).collect();
    let missing: Vec<_> = tops.iter().filter(|t| !LAYERS.contains(t)).collect();
    assert!(missing.is_empty(), "modules not placed in LAYERS (and ARCHITECTURE.md): {missing:?}");
}

#[test]
fn no_file_imports_itself_round_a_circle() {
    let graph = import_graph();
    // Tarjan's strongly connected components; a component of two or more files is a circle.
    struct Walk<'a> {
        graph: &'a BTreeMap<Module, BTreeSet<Module>>,
        index: BTreeMap<&'a Module, usize>,
        low: BTreeMap<&'a Module, usize>,
        stack: Vec<&'a Module>,
        circles: Vec<Vec<String>>,
    }
    impl<'a> Walk<'a> {
        fn visit(&mut self, v: &'a Module) {
            let i = self.index.len();
            self.index.insert(v, i);
            self.low.insert(v, i);
            self.stack.push(v);
            for w in self.graph.get(v).into_iter().flatten() {
                if !self.index.contains_key(w) {
                    self.visit(w);
                    let lw = self.low[w];
                    self.low.entry(v).and_modify(|l| *l = (*l).min(lw));
                } else if self.stack.contains(&w) {
                    let iw = self.index[w];
                    self.low.entry(v).and_modify(|l| *l = (*l).min(iw));
                }
            }
            if self.low[v] == self.index[v] {
                let mut component = Vec::new();
                while let Some(w) = self.stack.pop() {
                    component.push(name(w));
                    if w == v {
                        break;
                    }
                }
                if component.len() > 1 {
                    component.sort();
                    self.circles.push(component);
                }
            }
        }
    }
    let mut walk = Walk {
        graph: &graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        circles: Vec::new(),
    };
    for m in graph.keys() {
        if !walk.index.contains_key(m) {
            walk.visit(m);
        }
    }
    let lines: Vec<String> = walk.circles.iter().map(|c| c.join(", ")).collect();
    assert!(lines.is_empty(), "files that import each other round a circle:\n{}", lines.join("\n"));
}

#[test]
fn the_reader_sees_a_circle_and_an_upward_import() {
    // The checker itself, on a made-up crate: a <-> b, and bvh importing tracer.
    let known: BTreeSet<Module> =
        [vec!["bvh".to_string()], vec!["tracer".into()], vec!["tracer".into(), "frame".into()]]
            .into();
    let code = code_of("// use crate::gpu;\nuse crate::tracer::{frame::Accel, Image};\n#[cfg(test)]\nmod tests { use crate::app; }\nfn f() { super::tracer::frame::x(); }");
    let paths = named_paths(&code);
    let from = vec!["bvh".to_string()];
    let targets: BTreeSet<_> = paths.iter().filter_map(|p| resolve(&from, p, &known)).collect();
    assert_eq!(targets, [vec!["tracer".to_string(), "frame".into()], vec!["tracer".into()]].into());
    assert!(!paths.iter().any(|p| p.contains("gpu") || p.contains("app")), "{paths:?}");
}

#[test]
fn no_source_file_is_over_600_lines() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let long: Vec<String> = files
        .iter()
        .filter_map(|f| {
            let n = std::fs::read_to_string(f).unwrap().lines().count();
            (n > 600).then(|| format!("{} ({n} lines)", f.display()))
        })
        .collect();
    assert!(long.is_empty(), "files over 600 lines:\n{}", long.join("\n"));
}

//! The house rules of ARCHITECTURE.md, checked on the source text of `src/`:
//! - imports run down the layers ([`LAYERS`]), and inside `src/app/` down its folders
//!   ([`APP_ORDER`]); no two files import each other, directly or round a circle;
//! - Vulkan is named only in `src/gpu/`, and pipeline barriers only in `src/gpu/barrier.rs`;
//! - files are read and written only through `src/files/`;
//! - a user-facing `Range` is made only in `src/render_settings.rs`;
//! - no file over 600 lines, no function over 100.
//!
//! Code is read without its comments, string literals and `#[cfg(test)]` items (a test may
//! reach anywhere, and files named `tests.rs` or `*_tests.rs` are tests). Each failure lists
//! every offence as `file:line`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The top-level modules from the bottom up.
const LAYERS: &[&str] = &[
    "contract",
    "geometry",
    "memory",
    "render_settings",
    "files",
    "progress",
    "bvh",
    "scene",
    "tracer",
    "gpu",
    "bench",
    "app",
    "cli",
];

/// The folders and files of `src/app/` from the bottom up: one imports only those before it
/// (and `app` itself, the entry point, imports them all). `status` is a report line;
/// `split` the A/B split's settings; `options` what the tool starts with; `state` the
/// parameters and `shortcuts` the keys that change them; `user_files` loads and saves;
/// `measure` times frames (its logs named like screenshots); `panel` shows all of these;
/// `views` draw over the image with the panel's numbers; `tool` runs the window.
const APP_ORDER: &[&str] = &[
    "status",
    "split",
    "options",
    "state",
    "shortcuts",
    "user_files",
    "measure",
    "panel",
    "views",
    "tool",
];

/// The most lines a source file may have.
const MAX_FILE_LINES: usize = 600;

/// The most lines a function may have, from its `fn` line to its closing brace.
const MAX_FN_LINES: usize = 100;

type Module = Vec<String>;

/// A file of `src/`: its path from the crate root (`src/app/mod.rs`) and its text.
struct Source {
    path: String,
    text: String,
}

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

/// Every `.rs` file of `src/`, sorted by path.
fn sources() -> Vec<Source> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    rust_files(&root.join("src"), &mut files);
    files.sort();
    files
        .iter()
        .map(|f| Source {
            path: f.strip_prefix(root).unwrap().to_string_lossy().replace('\\', "/"),
            text: std::fs::read_to_string(f).unwrap(),
        })
        .collect()
}

/// Whether a file holds only tests (`mod tests;` behind `#[cfg(test)]`, by name).
fn is_test_file(path: &str) -> bool {
    path.ends_with("/tests.rs") || path.ends_with("_tests.rs")
}

/// The module a file defines: `src/a/b.rs` and `src/a/b/mod.rs` are `a::b`.
fn module_of(path: &str) -> Module {
    let rel = path.strip_prefix("src/").unwrap().strip_suffix(".rs").unwrap();
    let mut parts: Module = rel.split('/').map(String::from).collect();
    if matches!(parts.last().map(String::as_str), Some("mod" | "lib" | "main")) {
        parts.pop();
    }
    parts
}

/// The newlines of skipped text, so that line numbers of what is kept stay true.
fn newlines_of(skipped: &str) -> String {
    "\n".repeat(skipped.matches('\n').count())
}

/// The text without comments, string and char literals and `#[cfg(test)]` items, its
/// lines kept in place.
fn code_of(text: &str) -> String {
    without_test_items(&without_literals(text))
}

/// Comments dropped, string literals written `""` and char literals `' '`.
fn without_literals(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        let start = i;
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
        } else {
            let c = text[i..].chars().next().unwrap();
            out.push(c);
            i += c.len_utf8();
            continue;
        }
        out.push_str(&newlines_of(&text[start..i.min(text.len())]));
    }
    out
}

/// `#[cfg(test)]` items dropped from code without literals: each up to its `;` or the end
/// of its `{ ... }` (brackets counted, so `[T; 4]` does not end an item).
fn without_test_items(code: &str) -> String {
    let mut out = String::with_capacity(code.len());
    let mut rest = code;
    while let Some(at) = rest.find("#[cfg(test)]") {
        out.push_str(&rest[..at]);
        let item = &rest[at..];
        let mut depth = 0;
        let mut end = item.len();
        for (i, c) in item.char_indices() {
            match c {
                ';' if depth == 0 => {
                    end = i + 1;
                    break;
                }
                '{' | '[' | '(' => depth += 1,
                ']' | ')' => depth -= 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        end = i + 1;
                        break;
                    }
                }
                _ => {}
            }
        }
        out.push_str(&newlines_of(&item[..end]));
        rest = &item[end..];
    }
    out.push_str(rest);
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
    let files = sources();
    let known: BTreeSet<Module> = files.iter().map(|s| module_of(&s.path)).collect();
    files
        .iter()
        .map(|s| {
            let m = module_of(&s.path);
            let targets = named_paths(&code_of(&s.text))
                .iter()
                .filter_map(|p| resolve(&m, p, &known))
                .filter(|t| *t != m)
                .collect();
            (m, targets)
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

/// The imports that go up `order` (a module's place; `None` for one it does not rank).
fn upward(
    graph: &BTreeMap<Module, BTreeSet<Module>>,
    order: impl Fn(&Module) -> Option<usize>,
) -> Vec<String> {
    let mut up = Vec::new();
    for (from, targets) in graph {
        let Some(lf) = order(from) else { continue };
        for to in targets {
            if order(to).is_some_and(|lt| lt > lf) {
                up.push(format!("{} -> {}", name(from), name(to)));
            }
        }
    }
    up
}

/// A module's place in `src/app/`'s [`APP_ORDER`]; `app` itself is above every folder.
fn app_place(m: &Module) -> Option<usize> {
    match m.as_slice() {
        [app] if app == "app" => Some(APP_ORDER.len()),
        [app, folder, ..] if app == "app" => APP_ORDER.iter().position(|f| f == folder),
        _ => None,
    }
}

/// The circles of `graph` (Tarjan's strongly connected components of two or more
/// modules), each sorted by name.
fn circles(graph: &BTreeMap<Module, BTreeSet<Module>>) -> Vec<Vec<String>> {
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
                let seen = self.index.contains_key(w);
                if !seen {
                    self.visit(w);
                }
                if !seen || self.stack.contains(&w) {
                    let lw = if seen { self.index[w] } else { self.low[w] };
                    self.low.entry(v).and_modify(|l| *l = (*l).min(lw));
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
        graph,
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
    walk.circles
}

/// The 1-based lines of `code` where one of `needles` starts a word (a needle starting
/// with `.`, a method call, may follow anything), with the needle found.
fn find_words<'n>(code: &str, needles: &[&'n str]) -> Vec<(usize, &'n str)> {
    let mut found = Vec::new();
    for (n, line) in code.lines().enumerate() {
        for &needle in needles {
            let starts_word = |i: usize| {
                needle.starts_with('.')
                    || !line[..i].ends_with(|c: char| c.is_alphanumeric() || c == '_')
            };
            if line.match_indices(needle).any(|(i, _)| starts_word(i)) {
                found.push((n + 1, needle));
            }
        }
    }
    found
}

/// Every use of `needles` in the code of `src/` outside the files `allowed` passes and
/// test files, as `file:line: needle`.
fn used_outside(needles: &[&str], allowed: impl Fn(&str) -> bool) -> Vec<String> {
    let mut out = Vec::new();
    for s in sources().iter().filter(|s| !allowed(&s.path) && !is_test_file(&s.path)) {
        for (line, needle) in find_words(&code_of(&s.text), needles) {
            out.push(format!("{}:{line}: {needle}", s.path));
        }
    }
    out
}

/// The functions of `code` over `max` lines, as (line of `fn`, name, lines): from the
/// `fn` line to the brace that closes its body.
fn long_functions(code: &str, max: usize) -> Vec<(usize, String, usize)> {
    const QUALIFIERS: &[&str] =
        &["pub", "pub(crate)", "pub(super)", "const", "async", "unsafe", "extern", "\"\""];
    let lines: Vec<&str> = code.lines().collect();
    let mut long = Vec::new();
    for (start, line) in lines.iter().enumerate() {
        let Some((before, after)) = line.trim_start().split_once("fn ") else { continue };
        if !before.split_whitespace().all(|w| QUALIFIERS.contains(&w)) {
            continue;
        }
        let name: String = after.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
        // Count brackets from the `fn`: a `;` at depth 0 before any `{` is a declaration.
        let (mut depth, mut opened, mut end) = (0i32, false, None);
        'scan: for (n, l) in lines.iter().enumerate().skip(start) {
            let from = if n == start { l.find("fn ").unwrap() } else { 0 };
            for c in l[from..].chars() {
                match c {
                    ';' if depth == 0 => break 'scan,
                    '{' | '(' | '[' => {
                        opened |= c == '{';
                        depth += 1;
                    }
                    '}' | ')' | ']' => {
                        depth -= 1;
                        if depth == 0 && c == '}' && opened {
                            end = Some(n);
                            break 'scan;
                        }
                    }
                    _ => {}
                }
            }
        }
        if let Some(end) = end.filter(|end| end - start + 1 > max) {
            long.push((start + 1, name, end - start + 1));
        }
    }
    long
}

/// Fails with `what` and one offence a line unless there are none.
fn assert_none(offences: Vec<String>, what: &str) {
    assert!(offences.is_empty(), "{what} ({}):\n{}", offences.len(), offences.join("\n"));
}

#[test]
fn imports_run_down_the_layers() {
    let layer = |m: &Module| m.first().and_then(|top| LAYERS.iter().position(|l| l == top));
    assert_none(upward(&import_graph(), layer), "imports up the layers (ARCHITECTURE.md)");
}

#[test]
fn every_top_level_module_has_a_layer() {
    let graph = import_graph();
    let tops: BTreeSet<&str> = graph.keys().filter_map(|m| m.first().map(String::as_str)).collect();
    let missing: Vec<_> = tops.iter().filter(|t| !LAYERS.contains(t)).collect();
    assert!(missing.is_empty(), "modules not placed in LAYERS (and ARCHITECTURE.md): {missing:?}");
}

#[test]
fn imports_inside_the_app_run_down_its_folders() {
    assert_none(upward(&import_graph(), app_place), "imports up src/app/'s folders (APP_ORDER)");
}

#[test]
fn every_app_folder_has_a_place() {
    let graph = import_graph();
    let missing: BTreeSet<String> = graph
        .keys()
        .filter(|m| m.len() >= 2 && m[0] == "app" && app_place(m).is_none())
        .map(|m| m[1].clone())
        .collect();
    assert!(missing.is_empty(), "src/app/ folders not placed in APP_ORDER: {missing:?}");
}

#[test]
fn no_file_imports_itself_round_a_circle() {
    let lines: Vec<String> = circles(&import_graph()).iter().map(|c| c.join(", ")).collect();
    assert_none(lines, "files that import each other round a circle");
}

#[test]
fn the_circle_finder_finds_circles_and_only_circles() {
    let graph = |edges: &[(&str, &str)]| {
        let mut g: BTreeMap<Module, BTreeSet<Module>> = BTreeMap::new();
        for (a, b) in edges {
            g.entry(vec![a.to_string()]).or_default().insert(vec![b.to_string()]);
            g.entry(vec![b.to_string()]).or_default();
        }
        g
    };
    // a -> b -> c -> a, and d <-> e beside it, reached from c; f only imported.
    let g = graph(&[("a", "b"), ("b", "c"), ("c", "a"), ("c", "d"), ("d", "e"), ("e", "d")]);
    let mut found = circles(&g);
    found.sort();
    assert_eq!(found, [vec!["a", "b", "c"], vec!["d", "e"]]);
    // A diamond with a tail: no circle.
    let dag = graph(&[("a", "b"), ("a", "c"), ("b", "d"), ("c", "d"), ("d", "e")]);
    assert!(circles(&dag).is_empty());
}

#[test]
fn the_reader_sees_a_circle_and_an_upward_import() {
    // The checker itself, on a made-up crate: bvh importing tracer, and an app folder
    // importing one above it.
    let known: BTreeSet<Module> =
        [vec!["bvh".to_string()], vec!["tracer".into()], vec!["tracer".into(), "frame".into()]]
            .into();
    let code = code_of("// use crate::gpu;\nuse crate::tracer::{frame::Accel, Image};\n#[cfg(test)]\nmod tests { use crate::app; }\nfn f() { super::tracer::frame::x(); }");
    let paths = named_paths(&code);
    let from = vec!["bvh".to_string()];
    let targets: BTreeSet<_> = paths.iter().filter_map(|p| resolve(&from, p, &known)).collect();
    assert_eq!(targets, [vec!["tracer".to_string(), "frame".into()], vec!["tracer".into()]].into());
    assert!(!paths.iter().any(|p| p.contains("gpu") || p.contains("app")), "{paths:?}");
    let module = |s: &str| s.split("::").map(String::from).collect::<Module>();
    let graph = [(module("app::state"), [module("app::tool::ui"), module("app::options")].into())]
        .into_iter()
        .collect();
    assert_eq!(upward(&graph, app_place), ["app::state -> app::tool::ui"]);
}

#[test]
fn code_keeps_its_lines_and_loses_comments_strings_and_tests() {
    let text = "/* a\nb */ let x = \"fs::\nread\";\n#[cfg(test)]\nmod t {\n  const A: [u8; 2] = [0; 2];\n  fn f() { '}'; }\n}\nuse std::fs; // fs::\n";
    let code = code_of(text);
    assert_eq!(code.lines().count(), text.lines().count());
    assert_eq!(find_words(&code, &["fs::", "fs;", "read"]), [(9, "fs;")]);
    assert_eq!(
        find_words("a.canonicalize(); mfs::x; vk::Y", &[".canonicalize(", "fs::", "vk::"]).len(),
        2
    );
}

#[test]
fn vulkan_is_called_only_in_gpu() {
    let vulkan = &["ash::", "vk::", "ash_window"];
    assert_none(used_outside(vulkan, |p| p.starts_with("src/gpu/")), "Vulkan outside src/gpu/");
}

#[test]
fn every_pipeline_barrier_is_written_in_barrier_rs() {
    let barriers = &["cmd_pipeline_barrier"];
    let offences = used_outside(barriers, |p| p == "src/gpu/barrier.rs");
    assert_none(offences, "pipeline barriers outside src/gpu/barrier.rs");
}

#[test]
fn files_are_read_and_written_only_through_files() {
    let file_system = &[
        "fs::",
        "File::open",
        "File::create",
        "OpenOptions",
        ".canonicalize(",
        ".metadata(",
        ".read_dir(",
    ];
    // shader_compile.rs is also compiled into build.rs (`#[path]`), which has no crate to
    // call; it reads only our own shader sources.
    let allowed = |p: &str| p.starts_with("src/files/") || p == "src/gpu/shader_compile.rs";
    assert_none(used_outside(file_system, allowed), "file system calls outside src/files/");
}

#[test]
fn user_facing_ranges_are_made_only_in_render_settings() {
    let made = &["Range::closed(", "Range::open(", "Range {"];
    let offences = used_outside(made, |p| p == "src/render_settings.rs");
    assert_none(offences, "a Range made outside src/render_settings.rs");
}

#[test]
fn no_source_file_is_over_600_lines() {
    let long: Vec<String> = sources()
        .iter()
        .filter_map(|s| {
            let n = s.text.lines().count();
            (n > MAX_FILE_LINES).then(|| format!("{} ({n} lines)", s.path))
        })
        .collect();
    assert_none(long, "files over 600 lines");
}

#[test]
fn no_function_is_over_100_lines() {
    let mut long = Vec::new();
    for s in sources().iter().filter(|s| !is_test_file(&s.path)) {
        for (line, name, n) in long_functions(&code_of(&s.text), MAX_FN_LINES) {
            long.push(format!("{}:{line}: {name} ({n} lines)", s.path));
        }
    }
    assert_none(long, "functions over 100 lines");
}

#[test]
fn function_lengths_are_counted_from_fn_to_its_closing_brace() {
    let body = |n: usize| "    x();\n".repeat(n);
    let text = format!(
        "trait T {{\n    fn declared(&self, a: [u8; 2]);\n}}\npub(crate) fn long(\n    a: u32,\n) -> u32 {{\n{}}}\nfn short() {{ if true {{ }} }}\nimpl S {{\n    pub const fn nested() {{\n{}    }}\n}}\n",
        body(96),
        body(99)
    );
    // `long` runs from line 4 to its brace on line 103: 100 lines, at the limit; `nested`
    // from line 106 to the brace at its own indentation on line 206.
    assert_eq!(long_functions(&text, 100), [(106, "nested".to_string(), 101)]);
    assert_eq!(long_functions(&text, 99).len(), 2);
    assert_eq!(long_functions(&text, 99)[0], (4, "long".to_string(), 100));
}

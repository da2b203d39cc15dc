//! Assembles and compiles the GLSL compute shaders with naga: build.rs uses it for the
//! embedded SPIR-V, `view --watch-shaders` for hot reload, so both read the sources the same
//! way. It imports nothing from the crate (build.rs includes this file by path).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The generated header that shaders `#include` for the host's shared constants.
pub(crate) const CONTRACT_HEADER: &str = "contract.glsl";

/// A compiled shader: naga's module (for reflection) and its SPIR-V words.
pub(crate) struct CompiledShader {
    /// The validated module.
    pub module: naga::Module,
    /// SPIR-V words, debug info left out.
    pub spirv: Vec<u32>,
}

/// `contract.glsl` from the contract's `(name, value, doc)` list: one `const uint` per
/// constant, its doc as a comment; `source` names the Rust file in the header line.
pub(crate) fn contract_glsl(all: &[(&str, u32, &str)], source: &str) -> String {
    let mut out = format!("// Generated from {source} by build.rs: do not edit.\n\n");
    for (name, value, doc) in all {
        for line in doc.lines() {
            writeln!(out, "//{line}").unwrap();
        }
        let value = if *value > 0xffff { format!("0x{value:x}u") } else { format!("{value}u") };
        writeln!(out, "const uint {name} = {value};").unwrap();
    }
    out
}

/// GLSL source with its `#include`s expanded, and where each of its lines came from (so an
/// error in the expanded text can name the file and line the user edits).
pub(crate) struct Expanded {
    /// The source with every include in place.
    pub text: String,
    origin: Vec<(PathBuf, usize)>,
}

/// The shader at `path` with its includes expanded (`contract.glsl` from `contract` unless
/// one lies beside it): for naga here, and for glslang in build.rs (the vendor shaders).
pub(crate) fn expand(path: &Path, contract: &str) -> Result<Expanded, String> {
    let mut src = Expanded { text: String::new(), origin: Vec::new() };
    src.include(path, contract, 0)?;
    Ok(src)
}

impl Expanded {
    /// `file:line` of the 1-based line of the expanded text.
    pub(crate) fn locate(&self, line: u32) -> String {
        match self.origin.get((line as usize).saturating_sub(1)) {
            Some((path, n)) => format!("{}:{n}", path.display()),
            None => format!("line {line}"),
        }
    }

    // naga's GLSL front end has no preprocessor includes, so they are expanded here. A name
    // not found next to the including file is the generated contract header.
    fn include(&mut self, path: &Path, contract: &str, depth: u32) -> Result<(), String> {
        if depth >= 8 {
            return Err(format!("{}: #include nesting is deeper than 8", path.display()));
        }
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        for (n, line) in text.lines().enumerate() {
            if let Some(rest) = line.trim_start().strip_prefix("#include") {
                let name = rest.trim().trim_matches('"');
                let beside = path.parent().unwrap_or(Path::new(".")).join(name);
                if beside.exists() {
                    self.include(&beside, contract, depth + 1)?;
                } else if name == CONTRACT_HEADER {
                    for (i, l) in contract.lines().enumerate() {
                        self.push(l, PathBuf::from(CONTRACT_HEADER), i + 1);
                    }
                } else {
                    return Err(format!(
                        "{}:{}: cannot find the included file {name}",
                        path.display(),
                        n + 1
                    ));
                }
            }
            // The include line itself stays as an empty line, keeping the count simple.
            let kept = if line.trim_start().starts_with("#include") { "" } else { line };
            self.push(kept, path.to_path_buf(), n + 1);
        }
        Ok(())
    }

    fn push(&mut self, line: &str, path: PathBuf, n: usize) {
        self.text.push_str(line);
        self.text.push('\n');
        self.origin.push((path, n));
    }
}

/// Defined for `trace.comp`'s variant that takes its tiles in row order and records no
/// costs (for CPU devices; see `tile_order.rs`).
pub(crate) const ROW_ORDER: &str = "ROW_ORDER";

/// Defined for the trace kernel's core variant: without the AO view and the wide BVH, whose
/// code (a second traversal each) cost every frame 4-7% on the H200 through the registers it
/// takes (docs/BENCHMARKS.md); frames that use neither run it.
#[cfg_attr(not(test), allow(dead_code))] // the crate compiles it only in build.rs (and a test)
pub(crate) const CORE_ONLY: &str = "CORE_ONLY";

/// Defined for the trace kernel's wide variant: the wide BVH's closest-hit traversal
/// alone, without the binary traversal, brute force and the AO view, whose code made the
/// wide frames 2-11% slower on the H100 (docs/BENCHMARKS.md, "Twentieth session"). It runs
/// wide frames of one sample a pixel over scenes whose every mesh has a wide tree: without
/// the sample loop its walk takes 96 registers instead of 128 ("Thirty-fifth session").
#[cfg_attr(not(test), allow(dead_code))] // the crate compiles it only in build.rs (and a test)
pub(crate) const WIDE_ONLY: &str = "WIDE_ONLY";

/// Defined for the full, core and wide kernels' twins for scenes of one instance (a model
/// without the mirror box): it is visited without the top level's walk, whose stacks and
/// state cost those frames 10-13% on the H200 (docs/BENCHMARKS.md, "Twenty-seventh
/// session").
#[cfg_attr(not(test), allow(dead_code))] // the crate compiles it only in build.rs (and a test)
pub(crate) const ONE_INSTANCE: &str = "ONE_INSTANCE";

/// Defined, with `WIDE_ONLY`, for the wide kernel's twin for top levels with sphere leaves
/// (`contract::TOP_SPHERE`) or instances of convex meshes (`contract::FLAG_CONVEX`). The
/// wide kernel without it takes every leaf as a box and skips no instance: the spheres'
/// code in its walk cost the fields of 10,000 knots, which have none, 2-3% on the H200
/// (docs/BENCHMARKS.md, "Thirty-fourth session"), and the skip's 7% ("Thirty-seventh
/// session"). The other kernels do both always.
#[cfg_attr(not(test), allow(dead_code))] // the crate compiles it only in build.rs (and a test)
pub(crate) const SPHERE_LEAVES: &str = "SPHERE_LEAVES";

/// Defined for the trace kernel's leaf-runs variant (`--bvh wide-runs`): the wide traversal
/// tests the leaves pending on top of a ray's stack back to back (`traverse_wide.glsl`).
#[cfg_attr(not(test), allow(dead_code))] // the crate compiles it only in build.rs (and a test)
pub(crate) const LEAF_RUNS: &str = "LEAF_RUNS";

/// Compile the compute shader at `path` with the macros `defines` set (its includes expanded, `contract.glsl` from
/// `contract` unless one lies beside it). An error is one message starting with the
/// `file:line` of the first problem, naga's full report below it.
pub(crate) fn compile(
    path: &Path,
    contract: &str,
    defines: &[&str],
) -> Result<CompiledShader, String> {
    let src = expand(path, contract)?;
    let mut frontend = naga::front::glsl::Frontend::default();
    let mut options = naga::front::glsl::Options::from(naga::ShaderStage::Compute);
    options.defines.extend(defines.iter().map(|d| (d.to_string(), "1".to_string())));
    let module = frontend.parse(&options, &src.text).map_err(|e| {
        let (line, what) = match e.errors.first() {
            Some(first) => (first.meta.location(&src.text).line_number, first.kind.to_string()),
            None => (0, "unknown GLSL error".to_string()),
        };
        format!("{}: {what}\n{}", src.locate(line), e.emit_to_string(&src.text))
    })?;
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .map_err(|e| {
        let line =
            e.spans().next().map(|(span, _)| span.location(&src.text).line_number).unwrap_or(0);
        format!("{}: {}\n{}", src.locate(line), e.as_inner(), e.emit_to_string(&src.text))
    })?;
    let mut spv_options = naga::back::spv::Options::default();
    // Debug info would only grow the binary; bounds checks stay off (we index with validated data).
    spv_options.flags.remove(naga::back::spv::WriterFlags::DEBUG);
    let mut spirv = naga::back::spv::write_vec(&module, &info, &spv_options, None)
        .map_err(|e| format!("SPIR-V generation failed for {}: {e}", path.display()))?;
    drop_local_array_initializers(&mut spirv);
    Ok(CompiledShader { module, spirv })
}

/// Remove the zero initializer that naga's SPIR-V writer gives every function-local array
/// (WGSL's rule; GLSL has none). The traversal stack is such an array: zeroing its 64
/// entries on every traversal cost 256 bytes of local-memory stores per ray and instance,
/// for entries that are never read before they are pushed. Other locals keep theirs (the
/// driver drops dead scalar stores itself).
fn drop_local_array_initializers(words: &mut Vec<u32>) {
    const OP_TYPE_ARRAY: u32 = 28;
    const OP_TYPE_POINTER: u32 = 32;
    const OP_VARIABLE: u32 = 59;
    const STORAGE_FUNCTION: u32 = 7;
    const HEADER_WORDS: usize = 5;
    let mut arrays = std::collections::HashSet::new();
    let mut array_pointers = std::collections::HashSet::new();
    let mut keep = Vec::with_capacity(words.len());
    keep.extend_from_slice(&words[..HEADER_WORDS.min(words.len())]);
    let mut at = HEADER_WORDS;
    while at < words.len() {
        let count = ((words[at] >> 16) as usize).max(1);
        let inst = &words[at..(at + count).min(words.len())];
        at += count;
        let opcode = inst[0] & 0xffff;
        match opcode {
            OP_TYPE_ARRAY if inst.len() >= 2 => {
                arrays.insert(inst[1]);
            }
            OP_TYPE_POINTER if inst.len() >= 4 && arrays.contains(&inst[3]) => {
                array_pointers.insert(inst[1]);
            }
            _ => {}
        }
        if opcode == OP_VARIABLE
            && inst.len() == 5
            && inst[3] == STORAGE_FUNCTION
            && array_pointers.contains(&inst[1])
        {
            keep.push((4 << 16) | OP_VARIABLE);
            keep.extend_from_slice(&inst[1..4]);
        } else {
            keep.extend_from_slice(inst);
        }
    }
    *words = keep;
}

/// The interface the host relies on, as text: the work-group size, each storage binding
/// (number, block name, read-only) and the push-constant block's members with their offsets
/// and sizes. Two shaders with the same text fit the same pipeline layout and host structs.
pub(crate) fn layout_signature(module: &naga::Module) -> Result<String, String> {
    let mut layouter = naga::proc::Layouter::default();
    layouter
        .update(module.to_ctx())
        .map_err(|e| format!("cannot lay out the shader's types: {e}"))?;
    let [entry] = module.entry_points.as_slice() else {
        return Err("the shader must have exactly one entry point".into());
    };
    let mut lines = vec![format!("work group {:?}", entry.workgroup_size)];
    let mut bindings = Vec::new();
    for (_, var) in module.global_variables.iter() {
        let ty = &module.types[var.ty];
        let name = ty.name.clone().unwrap_or_default();
        match var.space {
            naga::AddressSpace::Storage { access } => {
                let b = var.binding.as_ref().ok_or("a storage buffer has no binding")?;
                let read_only =
                    if access.contains(naga::StorageAccess::STORE) { "" } else { " readonly" };
                bindings.push((
                    b.group,
                    b.binding,
                    format!("set {} binding {}: {name}{read_only}", b.group, b.binding),
                ));
            }
            naga::AddressSpace::PushConstant => {
                let mut line = format!("push constants {name}, {} bytes:", layouter[var.ty].size);
                if let naga::TypeInner::Struct { members, .. } = &ty.inner {
                    for m in members {
                        write!(
                            line,
                            " {}@{}+{}",
                            m.name.as_deref().unwrap_or("?"),
                            m.offset,
                            layouter[m.ty].size
                        )
                        .unwrap();
                    }
                }
                lines.push(line);
            }
            _ => {}
        }
    }
    bindings.sort();
    lines.extend(bindings.into_iter().map(|(_, _, line)| line));
    Ok(lines.join("\n"))
}

/// Every file a shader build reads from `dir` (the `.comp` and `.glsl` files), sorted.
pub(crate) fn shader_files(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir)? {
        let path = entry?.path();
        if path.extension().is_some_and(|e| e == "comp" || e == "glsl") {
            files.push(path);
        }
    }
    files.sort();
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// For each function-local array variable in `words`: whether it carries an initializer.
    fn local_arrays(words: &[u32]) -> Vec<bool> {
        let (mut arrays, mut pointers, mut found) = (Vec::new(), Vec::new(), Vec::new());
        let mut at = 5;
        while at < words.len() {
            let count = (words[at] >> 16) as usize;
            let inst = &words[at..at + count];
            match inst[0] & 0xffff {
                28 => arrays.push(inst[1]),
                32 if arrays.contains(&inst[3]) => pointers.push(inst[1]),
                59 if inst[3] == 7 && pointers.contains(&inst[1]) => found.push(inst.len() == 5),
                _ => {}
            }
            at += count;
        }
        found
    }

    #[test]
    fn local_arrays_lose_naga_s_zero_initializer_and_nothing_else_changes() {
        let dir = std::env::temp_dir().join(format!("meshtracer-spv-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("stack.comp");
        let source = "#version 450\nlayout(local_size_x = 1) in;\nlayout(std430, binding = 0) buffer B { uint v[]; };\n\
                      void main() { uint s[8]; float x = 2.0; for (uint i = 0u; i < 8u; i++) s[i] = v[i]; v[0] = s[v[1] & 7u] + uint(x); }\n";
        std::fs::write(&path, source).unwrap();
        let compiled = compile(&path, "", &[]).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();

        // naga's own output zero-initializes the array; ours does not, one word shorter.
        let info = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&compiled.module)
        .unwrap();
        let mut options = naga::back::spv::Options::default();
        options.flags.remove(naga::back::spv::WriterFlags::DEBUG);
        let raw = naga::back::spv::write_vec(&compiled.module, &info, &options, None).unwrap();
        assert_eq!(local_arrays(&raw), [true]);
        assert_eq!(local_arrays(&compiled.spirv), [false]);
        assert_eq!(compiled.spirv.len(), raw.len() - 1);
    }

    #[test]
    fn the_built_in_trace_shader_s_stack_is_not_zeroed() {
        let words = crate::gpu::trace_pass::built_in_trace_spirv();
        let arrays = local_arrays(&words);
        assert!(!arrays.is_empty(), "the traversal stack is a local array");
        assert!(arrays.iter().all(|&init| !init), "{arrays:?}");
    }
}

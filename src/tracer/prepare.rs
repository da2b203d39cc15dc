//! What packing a scene needs that costs time: every mesh's BVH built (in parallel with
//! the texture decoding), the diffuse textures and the environment map decoded. Done
//! before [`PackedScene::pack_tables`](super::PackedScene::pack_tables), which only copies.

use std::time::Instant;

use image::RgbaImage;
use rayon::prelude::*;

use super::textures::EnvironmentMap;
use crate::bvh::wide::{self, WideBvh};
use crate::bvh::{BuildOptions, Bvh};
use crate::render_settings::BvhLayout;
use crate::scene::{Scene, TextureSource};

/// Which BVH layouts a packing holds, and so which tree frames of each layout trace.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Layouts {
    /// The binary trees alone: wide frames trace them too.
    #[default]
    Binary,
    /// The wide trees, and binary nodes only for a mesh without one: the least memory (at
    /// 16M triangles the binary nodes are a third of the scene: 1.15 GB instead of 1.69).
    /// Binary frames trace the wide trees.
    Wide,
    /// Both, so that each frame may pick its layout (the window, which switches).
    Both,
}

impl Layouts {
    /// Frames of `layout` alone, in the least memory (`render`, `bench`).
    pub fn only(layout: BvhLayout) -> Self {
        if layout.is_wide() {
            Layouts::Wide
        } else {
            Layouts::Binary
        }
    }

    /// `layout`, with the binary trees beside wide ones (a load: the window switches).
    pub fn switchable(layout: BvhLayout) -> Self {
        if layout.is_wide() {
            Layouts::Both
        } else {
            Layouts::Binary
        }
    }

    /// Whether the wide trees are built (their collapse takes as long as the build).
    pub(crate) fn builds_wide(self) -> bool {
        self != Layouts::Binary
    }
}

/// A scene's BVHs (one per mesh, in mesh order), decoded textures and environment.
pub(crate) struct PreparedScene {
    pub bvhs: Vec<Bvh>,
    /// Each mesh's wide BVH, over its binary tree's (reordered) triangles, when the layouts
    /// asked for hold it.
    pub wide_bvhs: Vec<Option<WideBvh>>,
    /// Every readable diffuse texture, by the source materials name it with.
    pub textures: Vec<(TextureSource, RgbaImage)>,
    pub environment: Option<EnvironmentMap>,
    /// Problems worked around (unreadable textures or environment), reported by the caller.
    pub warnings: Vec<String>,
    /// Seconds spent building BVHs (and collapsing them into wide ones), for reports.
    pub bvh_build_seconds: f64,
    /// The layouts to pack: those asked for, or [`Layouts::Wide`] where both trees would
    /// not fit the device beside each other ([`NodeBudget`]).
    pub layouts: Layouts,
}

impl PreparedScene {
    /// Build the BVHs (and, where `layouts` holds the wide one, collapse each into it) and
    /// decode the images `scene` needs. With `node_limit` (the device's storage-buffer
    /// range), the trees are fitted to it ([`NodeBudget`]), and warnings say how.
    pub(crate) fn new(scene: &Scene, layouts: Layouts, node_limit: Option<u64>) -> Self {
        let wide = layouts.builds_wide();
        let (bvhs, textures) = rayon::join(
            || {
                let start = Instant::now();
                let mut budget = NodeBudget::new(layouts, node_limit);
                let mut warnings = Vec::new();
                let mut trees = Vec::with_capacity(scene.meshes.len());
                for mesh in &scene.meshes {
                    let options = BuildOptions::for_tracing(mesh.triangle_count());
                    let mut bvh =
                        Bvh::build_indexed(mesh.triangle_count(), |i| mesh.corners(i), &options);
                    // With `wide`, both trees (a packing may keep either or both): the wide
                    // tree is collapsed from the binary one, whose triangles it puts in its
                    // own leaf order. Only on request (the collapse takes as long as the
                    // build) and where it fits. A tree whose traversal could overflow the
                    // shader's stack (none of the meshes measured comes near) keeps the
                    // binary layout alone.
                    let wide_bvh = if wide {
                        let room = budget.wide_room();
                        match wide::collapse_within(&mut bvh, room) {
                            Ok(w) => Some(w).filter(|w| w.stack_need() <= wide::STACK_SIZE),
                            Err(nodes) => {
                                warnings.push(budget.refusal(mesh, nodes));
                                None
                            }
                        }
                    } else {
                        None
                    };
                    warnings.extend(budget.place(mesh, &bvh, wide_bvh.as_ref()));
                    trees.push((bvh, wide_bvh));
                }
                let (bvhs, wide_bvhs): (Vec<Bvh>, Vec<Option<WideBvh>>) = trees.into_iter().unzip();
                let seconds = start.elapsed().as_secs_f64();
                (bvhs, wide_bvhs, budget.layouts, warnings, seconds)
            },
            || decode_textures(scene),
        );
        let (
            (bvhs, wide_bvhs, layouts, budget_warnings, bvh_build_seconds),
            (textures, mut warnings),
        ) = (bvhs, textures);
        warnings.extend(budget_warnings);
        let (environment, env_warning) = EnvironmentMap::from_source(scene.environment.as_ref());
        warnings.extend(env_warning);
        Self { bvhs, wide_bvhs, layouts, textures, environment, warnings, bvh_build_seconds }
    }
}

/// The BVH node buffer's bytes so far, mesh by mesh, against the device's storage-buffer
/// range: which trees it can hold. For each mesh it holds the wide nodes and (with
/// [`Layouts::Both`], or where the mesh has no wide tree) the binary nodes. Where both trees
/// would not fit beside each other (the window keeps both: at 100M triangles 3.67 GB of
/// binary nodes and 0.70 GB of wide ones, past the 4.29 GB an H200 storage buffer may span),
/// the packing keeps the wide trees alone, as `render` does, and binary frames trace them.
/// A mesh whose wide tree would still pass the range keeps its binary tree, which both
/// kinds of frames then trace. What still does not fit is refused at the upload.
struct NodeBudget {
    layouts: Layouts,
    limit: Option<u64>,
    /// Bytes of every mesh's binary nodes placed so far.
    binary: u64,
    /// Bytes of the wide nodes of the meshes that keep a wide tree, and of those meshes'
    /// binary nodes (which a packing of the wide trees alone leaves out). Running sums: a
    /// glTF scene may hold thousands of meshes.
    wide: u64,
    binary_beside_wide: u64,
}

impl NodeBudget {
    fn new(layouts: Layouts, limit: Option<u64>) -> Self {
        Self { layouts, limit, binary: 0, wide: 0, binary_beside_wide: 0 }
    }

    /// The bytes of the meshes placed so far, packed as `layouts`.
    fn used(&self, layouts: Layouts) -> u64 {
        match layouts {
            Layouts::Both => self.binary + self.wide,
            _ => self.binary - self.binary_beside_wide + self.wide,
        }
    }

    /// The most nodes the next mesh's wide tree may have to fit after the meshes placed so
    /// far, the binary trees dropped if need be ([`Layouts::Wide`]).
    fn wide_room(&self) -> usize {
        let Some(limit) = self.limit else { return usize::MAX };
        let room = limit.saturating_sub(self.used(Layouts::Wide));
        (room / WIDE_NODE_BYTES) as usize
    }

    /// Counts in the nodes of `mesh`, with binary tree `bvh` and `wide` tree if it keeps
    /// one; where both trees no longer fit beside each other, the packing keeps the wide
    /// trees alone from here on, and the warning says so.
    fn place(
        &mut self,
        mesh: &crate::scene::Mesh,
        bvh: &Bvh,
        wide: Option<&WideBvh>,
    ) -> Option<String> {
        let binary = bvh.nodes.len() as u64 * BINARY_NODE_BYTES;
        self.binary += binary;
        if let Some(w) = wide {
            self.wide += w.nodes.len() as u64 * WIDE_NODE_BYTES;
            self.binary_beside_wide += binary;
        }
        let limit = self.limit?;
        let both = self.used(Layouts::Both);
        // Without a wide tree the two packings are the same bytes.
        if self.layouts != Layouts::Both || both <= limit || self.wide == 0 {
            return None;
        }
        self.layouts = Layouts::Wide;
        Some(format!(
            "{}: the binary and wide BVHs together would take the BVH nodes to {:.2} GB, past \
             the device's storage-buffer range ({:.2} GB), so the wide BVHs alone are kept \
             ({:.2} GB) and binary frames trace them",
            mesh.name,
            both as f64 / 1e9,
            limit as f64 / 1e9,
            self.used(Layouts::Wide) as f64 / 1e9,
        ))
    }

    /// The warning for `mesh`, whose wide tree of `nodes` nodes did not fit.
    fn refusal(&self, mesh: &crate::scene::Mesh, nodes: usize) -> String {
        let with = self.used(Layouts::Wide) + nodes as u64 * WIDE_NODE_BYTES;
        format!(
            "{}: its wide BVH would take the BVH nodes to {:.2} GB, past the device's \
             storage-buffer range ({:.2} GB), so its binary BVH is traced instead",
            mesh.name,
            with as f64 / 1e9,
            self.limit.unwrap_or(u64::MAX) as f64 / 1e9,
        )
    }
}

const BINARY_NODE_BYTES: u64 = std::mem::size_of::<crate::bvh::BvhNode>() as u64;
const WIDE_NODE_BYTES: u64 = std::mem::size_of::<wide::WideNode>() as u64;

/// Decode every textured material's diffuse texture (in parallel), files read from disk and
/// embedded images from their bytes; unreadable ones are warnings, and their materials keep
/// their Kd.
fn decode_textures(scene: &Scene) -> (Vec<(TextureSource, RgbaImage)>, Vec<String>) {
    // In first-seen order, each source once (an embedded image is hashed by its bytes,
    // so one shared by several materials or meshes is decoded once).
    let mut seen = std::collections::HashSet::new();
    let sources: Vec<&TextureSource> = scene
        .meshes
        .iter()
        .filter(|m| !m.texcoords.is_empty())
        .flat_map(|m| m.materials.iter().filter_map(|mat| mat.diffuse_texture.as_ref()))
        .filter(|s| seen.insert(*s))
        .collect();
    let decoded: Vec<_> = sources.par_iter().map(|s| ((*s).clone(), decode_texture(s))).collect();
    let mut textures = Vec::new();
    let mut warnings = Vec::new();
    for (source, result) in decoded {
        match result {
            Ok(img) => textures.push((source, img)),
            Err(e) => warnings.push(format!(
                "{}; using the material's Kd instead",
                crate::files::shown(&e, 2 * crate::files::MAX_QUOTED_NAME)
            )),
        }
    }
    (textures, warnings)
}

/// One texture's image as RGBA8, or why it cannot be read (one sentence naming it).
fn decode_texture(source: &TextureSource) -> Result<RgbaImage, String> {
    match source {
        TextureSource::File(path) => {
            crate::files::read_image(path, "texture").map(|i| i.to_rgba8())
        }
        TextureSource::Embedded { name, bytes } => image::load_from_memory(bytes)
            .map(|i| i.to_rgba8())
            .map_err(|e| format!("cannot read texture {name}: {e}")),
    }
}

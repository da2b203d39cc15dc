//! What packing a scene needs that costs time: every mesh's BVH built (in parallel with
//! the texture decoding), the diffuse textures and the environment map decoded. Done
//! before [`PackedScene::pack_tables`](super::PackedScene::pack_tables), which only copies.

use std::time::Instant;

use image::RgbaImage;
use rayon::prelude::*;

use super::textures::EnvironmentMap;
use crate::bvh::wide::{self, WideBvh};
use crate::bvh::{BuildOptions, Bvh, BvhNode};
use crate::render_settings::BvhLayout;
use crate::scene::{Mesh, Scene, TextureSource};

/// From how many triangles a mesh's BVHs are built on the device, where the device builds
/// them ([`DeviceFit::builds_from`]) and the user did not say: the CPU takes 0.4 s at 10M
/// triangles and 4 s at 100M on 16 cores (8 s with the wide tree), an H200 0.4-0.9 s at
/// 100M, but its trees (Morton order) trace 1.2-1.3x slower (docs/BENCHMARKS.md).
pub const DEVICE_BUILD_FROM: usize = 50_000_000;

/// The triangles a leaf of a tree built on the device may hold (the last leaf fewer): the
/// least whose nodes fit the node buffer ([`device_leaf_size`]).
pub const DEVICE_LEAF_SIZES: [u32; 4] = [1, 2, 4, 8];

/// The fewest triangles a mesh has to be built on the device even when asked for every
/// mesh: a smaller one is a leaf or two, and the mirror box's triangles keep the CPU
/// tree's order (its closed-box test reads them).
const DEVICE_BUILD_LEAST: usize = 64;

/// Where a scene's BVHs are built.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BvhBuilder {
    /// On the device for meshes of at least [`DEVICE_BUILD_FROM`] triangles.
    #[default]
    Auto,
    /// On the CPU (binned SAH), every mesh.
    Cpu,
    /// On the device (a linear BVH), every mesh but the smallest.
    Device,
}

impl std::str::FromStr for BvhBuilder {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(BvhBuilder::Auto),
            "cpu" => Ok(BvhBuilder::Cpu),
            "device" | "gpu" => Ok(BvhBuilder::Device),
            _ => Err(format!("{s:?} is not a BVH builder: expected auto, cpu or device")),
        }
    }
}

impl std::fmt::Display for BvhBuilder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            BvhBuilder::Auto => "auto",
            BvhBuilder::Cpu => "cpu",
            BvhBuilder::Device => "device",
        })
    }
}

/// What the device a scene is packed for can hold and do: the bytes a storage buffer may
/// span (the node buffer is fitted to it, [`NodeBudget`]), and from how many triangles it
/// builds a mesh's BVHs itself (`gpu::bvh_build`) after the upload.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DeviceFit {
    pub storage_range: Option<u64>,
    pub builds_from: Option<usize>,
}

impl DeviceFit {
    /// No device: every tree is built on the CPU, and nothing is fitted.
    pub const NONE: DeviceFit = DeviceFit { storage_range: None, builds_from: None };

    /// A device whose storage buffers span `storage_range` bytes, building trees as
    /// `builder` says; `auto` leaves none to a device that is no faster than the host
    /// (`gpu_device` false: lavapipe runs the build on the CPU, one core a work group).
    pub fn new(storage_range: u64, builder: BvhBuilder, gpu_device: bool) -> Self {
        let builds_from = match builder {
            BvhBuilder::Auto => gpu_device.then_some(DEVICE_BUILD_FROM),
            BvhBuilder::Cpu => None,
            BvhBuilder::Device => Some(0),
        };
        Self { storage_range: Some(storage_range), builds_from }
    }

    /// Whether `mesh`'s trees are left to the device.
    pub(crate) fn builds(&self, mesh: &Mesh) -> bool {
        self.builds_from.is_some_and(|from| mesh.triangle_count() >= from.max(DEVICE_BUILD_LEAST))
    }
}

/// The triangles a leaf holds in the device's tree over `triangles`: the fewest of
/// [`DEVICE_LEAF_SIZES`] whose nodes (one a leaf but one) fit in `room` bytes.
pub(crate) fn device_leaf_size(triangles: usize, room: u64) -> u32 {
    let fits = |&l: &u32| (triangles.div_ceil(l as usize) as u64 - 1) * BINARY_NODE_BYTES <= room;
    DEVICE_LEAF_SIZES.into_iter().find(fits).unwrap_or(DEVICE_LEAF_SIZES[3])
}

/// The most wide nodes the device's collapse makes of a binary tree of `leaves` leaves, so
/// many reserved for it. A wide node is full (eight children) unless its binary subtree has
/// fewer than eight leaves, when it holds the subtree whole; counting the W nodes' children
/// (W - 1 nodes and `leaves` leaves) against eight a full node and two a small one, and the
/// small ones' disjoint leaves: 7W <= 4 leaves - 1. Its stack guard (`collapse.comp`) may
/// stop a node short of eight where the tree is deep; a tree that needs more than this
/// reserve is refused at the upload.
pub(crate) fn device_wide_nodes(leaves: usize) -> usize {
    (4 * leaves).div_ceil(7) + 1
}

/// The stand-ins for the trees the device will build over `mesh`: the binary tree's nodes
/// reserved (zero) with its triangles in file order, which the build reorders in place, and
/// with `wide`, the wide tree's nodes, where they fit: its leaves hold one triangle or two
/// (a wide leaf slot holds three at most), its binary tree fits a storage buffer of
/// `storage_range` bytes, and its wide nodes fit the node buffer (`budget`). Otherwise the
/// binary tree alone, its leaves as small as fit. Returns the leaf size with them.
fn reserved_for_device(
    mesh: &Mesh,
    wide: bool,
    storage_range: Option<u64>,
    budget: &NodeBudget,
) -> (Bvh, Option<WideBvh>, u32) {
    let n = mesh.triangle_count();
    let binary_bytes = |leaf: u32| (n.div_ceil(leaf as usize) as u64 - 1) * BINARY_NODE_BYTES;
    let wide_leaf = DEVICE_LEAF_SIZES[..2].iter().copied().find(|&leaf| {
        let nodes = device_wide_nodes(n.div_ceil(leaf as usize));
        binary_bytes(leaf) <= storage_range.unwrap_or(u64::MAX) && nodes <= budget.wide_room()
    });
    let (leaf_size, wide) = match wide_leaf.filter(|_| wide) {
        Some(leaf) => {
            let nodes = device_wide_nodes(n.div_ceil(leaf as usize));
            (leaf, Some(WideBvh { nodes: bytemuck::zeroed_vec(nodes) }))
        }
        None => (device_leaf_size(n, budget.room()), None),
    };
    let mut prim_indices = Vec::new();
    prim_indices.par_extend((0..n as u32).into_par_iter());
    // Zeroed memory: pages the upload reads without the host writing them.
    let leaves = n.div_ceil(leaf_size as usize);
    let bvh = Bvh { nodes: bytemuck::zeroed_vec::<BvhNode>(leaves - 1), prim_indices };
    (bvh, wide, leaf_size)
}

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
    /// Per mesh whose trees are left to the device (`bvhs` and `wide_bvhs` hold the
    /// [`reserved_for_device`] stand-ins): the triangles its leaves hold.
    pub on_device: Vec<Option<u32>>,
    /// The layouts to pack: those asked for, or [`Layouts::Wide`] where both trees would
    /// not fit the device beside each other ([`NodeBudget`]).
    pub layouts: Layouts,
}

impl PreparedScene {
    /// Build the BVHs (and, where `layouts` holds the wide one, collapse each into it) and
    /// decode the images `scene` needs. For a `device` the trees are fitted to its
    /// storage-buffer range ([`NodeBudget`]), warnings saying how, and the meshes it builds
    /// itself get stand-ins ([`reserved_for_device`]).
    pub(crate) fn new(scene: &Scene, layouts: Layouts, device: DeviceFit) -> Self {
        let wide = layouts.builds_wide();
        let (bvhs, textures) = rayon::join(
            || {
                let start = Instant::now();
                let mut budget = NodeBudget::new(layouts, device.storage_range);
                let mut warnings = Vec::new();
                let mut trees = Vec::with_capacity(scene.meshes.len());
                for mesh in &scene.meshes {
                    if device.builds(mesh) {
                        let (bvh, wide_bvh, leaf_size) =
                            reserved_for_device(mesh, wide, device.storage_range, &budget);
                        warnings.extend(budget.place(mesh, &bvh, wide_bvh.as_ref()));
                        trees.push((bvh, wide_bvh, Some(leaf_size)));
                        continue;
                    }
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
                    trees.push((bvh, wide_bvh, None));
                }
                let mut bvhs = Vec::with_capacity(trees.len());
                let mut wide_bvhs = Vec::with_capacity(trees.len());
                let mut on_device = Vec::with_capacity(trees.len());
                for (bvh, wide_bvh, device) in trees {
                    bvhs.push(bvh);
                    wide_bvhs.push(wide_bvh);
                    on_device.push(device);
                }
                let seconds = start.elapsed().as_secs_f64();
                (bvhs, wide_bvhs, on_device, budget.layouts, warnings, seconds)
            },
            || decode_textures(scene),
        );
        let (
            (bvhs, wide_bvhs, on_device, layouts, budget_warnings, bvh_build_seconds),
            (textures, mut warnings),
        ) = (bvhs, textures);
        warnings.extend(budget_warnings);
        let (environment, env_warning) = EnvironmentMap::from_source(scene.environment.as_ref());
        warnings.extend(env_warning);
        Self {
            bvhs,
            wide_bvhs,
            on_device,
            layouts,
            textures,
            environment,
            warnings,
            bvh_build_seconds,
        }
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

    /// The bytes left for the next mesh's nodes, every tree so far kept (`u64::MAX`
    /// without a limit).
    fn room(&self) -> u64 {
        self.limit.map_or(u64::MAX, |l| l.saturating_sub(self.used(self.layouts)))
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
    fn place(&mut self, mesh: &Mesh, bvh: &Bvh, wide: Option<&WideBvh>) -> Option<String> {
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
    fn refusal(&self, mesh: &Mesh, nodes: usize) -> String {
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

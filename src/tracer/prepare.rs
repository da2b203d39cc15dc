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
}

impl PreparedScene {
    /// Build the BVHs (and, where `layouts` holds the wide one, collapse each into it) and
    /// decode the images `scene` needs.
    pub(crate) fn new(scene: &Scene, layouts: Layouts) -> Self {
        let wide = layouts.builds_wide();
        let (bvhs, textures) = rayon::join(
            || {
                let start = Instant::now();
                // With `wide`, both trees (a packing may keep either or both): the wide tree is
                // collapsed from the binary one, whose triangles it puts in its own leaf
                // order. Only on request: the collapse takes as long as the build.
                let (bvhs, wide_bvhs): (Vec<Bvh>, Vec<Option<WideBvh>>) = scene
                    .meshes
                    .iter()
                    .map(|mesh| {
                        let options = BuildOptions::for_tracing(mesh.triangle_count());
                        let mut bvh = Bvh::build_indexed(
                            mesh.triangle_count(),
                            |i| mesh.corners(i),
                            &options,
                        );
                        // A tree whose traversal could overflow the shader's stack (none of
                        // the meshes measured comes near) keeps the binary layout alone.
                        let wide = wide
                            .then(|| wide::collapse(&mut bvh))
                            .filter(|w| w.stack_need() <= wide::STACK_SIZE);
                        (bvh, wide)
                    })
                    .unzip();
                (bvhs, wide_bvhs, start.elapsed().as_secs_f64())
            },
            || decode_textures(scene),
        );
        let ((bvhs, wide_bvhs, bvh_build_seconds), (textures, mut warnings)) = (bvhs, textures);
        let (environment, env_warning) = EnvironmentMap::from_source(scene.environment.as_ref());
        warnings.extend(env_warning);
        Self { bvhs, wide_bvhs, textures, environment, warnings, bvh_build_seconds }
    }
}

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

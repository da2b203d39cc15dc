// The constants that the host and `shaders/*.glsl` must agree on, declared once here.
//
// build.rs `include!`s this file and writes every constant of `ALL` into the GLSL header
// `contract.glsl` (OUT_DIR), which `shaders/scene.glsl` includes; the Rust side uses the
// consts directly. So this file holds plain `u32` consts only: no `crate::` paths and no
// inner doc comments, which `include!` into build.rs could not take.

/// Declares each constant as a `pub const NAME: u32` and lists them all in [`ALL`] (name,
/// value, doc), the table build.rs turns into `contract.glsl`.
macro_rules! contract {
    ($($(#[doc = $doc:literal])+ $name:ident = $value:expr;)+) => {
        $($(#[doc = $doc])+ pub const $name: u32 = $value;)+

        /// Every constant of the contract as (name, value, doc), in declaration order.
        // Read by build.rs (which `include!`s this file), not by the crate itself.
        #[allow(dead_code)]
        pub const ALL: &[(&str, u32, &str)] = &[$((stringify!($name), $name, concat!($($doc, "\n"),+))),+];
    };
}

contract! {
    /// An absent index: a BVH child that is not there, a material without texture, a miss.
    EMPTY = u32::MAX;
    /// Entries in the BVH traversal stack (CPU and shader alike).
    STACK_SIZE = 64;
    /// Entries in the wide BVH traversal's stack: one per pending child, so a visit pushes
    /// up to seven (`WideBvh::stack_need` of a traced tree stays within it).
    WIDE_STACK_SIZE = 128;
    /// Bytes of padding after the last triangle: the shaders load triangles as 16-byte words
    /// (`load_triangle`, `load_triangle_pair` for a wide leaf's first two, which may read
    /// the words of a triangle past the last one).
    TRIANGLE_READ_AHEAD = 48;
    /// The count of a top-level leaf that is the scene's enclosure (the paper's mirror box:
    /// a few triangles whose box holds every other instance): the root's left child,
    /// tested triangle by triangle before the walk (`top_level.rs`). Other top-level leaves
    /// count 1.
    TOP_ENCLOSURE = 2;
    /// The count of a top-level leaf that holds its instance's world bounding sphere in
    /// place of its box (centre in the min corner, radius in the max corner's x), tested
    /// by the walk before the instance is visited (`top_level.rs`, `fit_spheres`).
    TOP_SPHERE = 3;
    /// A mesh's convexity (`GpuMesh::convex`): convex, every vertex behind each of its
    /// triangles' planes as the triangle's winding faces (cross(e1, e2) points out). A ray
    /// that leaves such a mesh's triangle from outside cannot meet the mesh again, and the
    /// next ray skips its instance (`tracer/convex.rs`).
    CONVEX_OUTWARD = 1;
    /// A mesh's convexity: convex with every triangle wound to face in (cross(e1, e2)
    /// points into the mesh), as the mirror box's walls are. 0: not known to be convex.
    CONVEX_INWARD = 2;

    // The flag word, `dims.w` of the push constants (`FrameParams::flags`).

    /// Flag: find closest hits through the BVH (else the paper's brute force).
    FLAG_BVH = 1;
    /// Where the AOV code sits in the flag word.
    AOV_SHIFT = 1;
    /// The AOV code's bits once shifted down (3 bits).
    AOV_MASK = 0b111;
    /// Flag: interpolate vertex normals (smooth shading).
    FLAG_SMOOTH = 1 << 4;
    /// Flag: apply diffuse textures and vertex colours.
    FLAG_TEXTURES = 1 << 5;
    /// Flag: misses see the environment map instead of the background colour.
    FLAG_ENVIRONMENT = 1 << 6;
    /// Flag: spend the extra samples only on edge pixels (adaptive sampling).
    FLAG_ADAPTIVE = 1 << 7;
    /// Flag: adaptive sampling's pre-pass, which writes the path keys only.
    FLAG_ID_PASS = 1 << 8;
    /// Flag: some top-level leaf is a sphere (`TOP_SPHERE`); without it the walk tests
    /// every leaf as a box and skips the check.
    FLAG_SPHERES = 1 << 9;
    /// Flag: some instance the walk visits has a convex mesh (`CONVEX_OUTWARD`,
    /// `CONVEX_INWARD`), so a ray may skip the instance it leaves; wide frames then run the
    /// wide kernel's twin, as for `FLAG_SPHERES`, since the plain wide kernel leaves the
    /// skip out. Read by the host only.
    FLAG_CONVEX = 1 << 10;
    /// Flag: the walk visits many instances (`top_level::WARP_BLOCKS_FROM`), so each
    /// subgroup traces an 8x4 block of its tile instead of a 32-pixel row (`tile_pixel` in
    /// `shaders/trace.comp`): lanes of one block meet fewer instances.
    FLAG_WARP_BLOCKS = 1 << 11;
    /// Flag: with `FLAG_BVH`, traverse the compressed wide BVH (`--bvh wide`) instead of
    /// the binary one.
    FLAG_WIDE = 1 << 15;
    /// Flag: with `FLAG_WIDE`, a ray tests the leaves pending on top of its stack back to
    /// back before its next node visit (`--bvh wide-runs`): the host runs the kernel built
    /// with `LEAF_RUNS` for such frames.
    FLAG_LEAF_RUNS = 1 << 14;
    /// Where the samples per pixel sit in the flag word.
    SPP_SHIFT = 16;
    /// The samples-per-pixel bits once shifted down (8 bits).
    SPP_MASK = 0xff;

    // `dims.z` of the push constants (`FrameParams::push_constants`): the bounces in its
    // low byte, then the band's lanes (`PushConstants::set_lanes`). A band finer than a
    // work group traces only lanes `first..=first + span` of its group (lane = y * width
    // + x within the group's tile); every other band has first 0 and span `LANE_MASK`.

    /// The mirror bounces' bits of `dims.z` (at most `MAX_BOUNCES`, far below).
    BOUNCES_MASK = 0xff;
    /// Where the band's first lane sits in `dims.z`.
    FIRST_LANE_SHIFT = 8;
    /// Where the band's lanes after its first (its span) sit in `dims.z`.
    LANE_SPAN_SHIFT = 16;
    /// The bits of the first lane and of the span once shifted down (work groups of at
    /// most 256 invocations).
    LANE_MASK = 0xff;

    // AOV codes (`Aov::code`), at `AOV_SHIFT` in the flag word.

    /// AOV: shaded colour.
    AOV_COLOR = 0;
    /// AOV: primary-hit distance.
    AOV_DEPTH = 1;
    /// AOV: primary-hit normal.
    AOV_NORMAL = 2;
    /// AOV: primary-hit triangle index (file order).
    AOV_PRIM_ID = 3;
    /// AOV: BVH nodes visited and triangles tested.
    AOV_COST = 4;
    /// AOV: camera samples spent on the pixel.
    AOV_SAMPLES = 5;
    /// AOV: ambient occlusion, the fraction of cosine-weighted rays from the primary hit
    /// that meet nothing within the AO radius (the radius in `light_pos.w`, the rays per
    /// hit in `light_color.w` as uint bits).
    AOV_AO = 6;
    /// Salt of the AO rays' seeds, so their random numbers are not the camera jitter's.
    AO_SEED_SALT = 0x68e3_1da4;

    // Texture flags of a material (`GpuMaterial::texture_flags`, `Material.texture.y`).

    /// Texture flag: coordinates clamp to [0, 1] and the edge texels (`map_Kd -clamp on`)
    /// instead of repeating.
    TEXTURE_CLAMP = 1;
    /// Material flag (same word): the material's mesh has vertex colours, which multiply its
    /// diffuse colour when `FLAG_TEXTURES` is set.
    MATERIAL_VERTEX_COLORS = 2;

    // Descriptor bindings of the vendor shaders (`shaders/vendor/tlas.glsl`) beyond the
    // storage buffers, which the shaders' reflection numbers.

    /// Binding of the driver's top-level acceleration structure, after the storage buffers.
    TLAS_BINDING = 11;
    /// Binding of the vendor shaders' slot map (`vendor_slots`).
    VENDOR_SLOTS_BINDING = 18;
}

// The fields of the flag word must not overlap, and every AOV code must fit its bits.
const _: () = {
    let flags = FLAG_BVH
        | FLAG_WIDE
        | FLAG_LEAF_RUNS
        | FLAG_SMOOTH
        | FLAG_TEXTURES
        | FLAG_ENVIRONMENT
        | FLAG_ADAPTIVE
        | FLAG_ID_PASS
        | FLAG_SPHERES
        | FLAG_CONVEX
        | FLAG_WARP_BLOCKS;
    let (aov, spp) = (AOV_MASK << AOV_SHIFT, SPP_MASK << SPP_SHIFT);
    assert!(flags & aov == 0 && flags & spp == 0 && aov & spp == 0);
    assert!(AOV_SAMPLES <= AOV_MASK && AOV_AO <= AOV_MASK);
    // Nor the fields of dims.z.
    let (bounces, first, span) =
        (BOUNCES_MASK, LANE_MASK << FIRST_LANE_SHIFT, LANE_MASK << LANE_SPAN_SHIFT);
    assert!(bounces & first == 0 && bounces & span == 0 && first & span == 0);
};

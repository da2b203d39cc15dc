//! Costliest tiles first: the order in which the trace pass's work groups take the frame's
//! tiles (one tile of `GROUP` pixels per group).
//!
//! A GPU starts work groups roughly in the order of their index, and a frame lasts until
//! its slowest tile is done. Traced in rows, a model's costly tiles may come last and run
//! alone at the end while the rest of the GPU idles. So each frame the trace shader records
//! what every tile cost (BVH nodes visited plus triangles tested, the cost AOV's counts,
//! sampled as below) and the next frame of the same slot dispatches its tiles in falling order of that cost
//! (longest-processing-time-first scheduling). Only the order changes, never a pixel: a
//! stale or empty record (a new resolution, a moved camera) costs speed, not correctness.
//! On the H100 this took 10-17% off primary rays into 1M-10M-triangle meshes, 11-24% off
//! the mirror box with them or the dragon, for 0-6% more on the paper's small scenes
//! (docs/BENCHMARKS.md, "Costliest tiles first"). CPU devices keep row order
//! (`Kernel::OursInRowOrder`): lavapipe traced 1.4-2x slower in cost order.
//!
//! Each timestamp slot (a frame in flight of the window, and the headless path) has its own
//! range of both buffers, so the host rewrites one slot's order while another's frame runs.
//! Both are host-visible: the host writes the order and reads the costs in place.
//!
//! What a tile cost is sampled, not summed: the pixel in the middle of each of its rows
//! records its count, and the host adds the samples up. (Summing all 128 pixels takes a
//! work-group barrier, which cost the H100 about 0.04 ms a frame.)

use std::ops::Range;
use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::buffer::GpuBuffer;
use super::context::GpuContext;
use super::dispatch::{Band, GROUP};
use super::error::GpuError;

/// A rectangle of tiles (in tile units) that one dispatch covers.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct TileRect {
    pub columns: Range<u32>,
    pub rows: Range<u32>,
}

impl TileRect {
    /// The two rects share a tile.
    fn overlaps(&self, other: &TileRect) -> bool {
        let apart = |a: &Range<u32>, b: &Range<u32>| {
            a.is_empty() || b.is_empty() || a.end <= b.start || b.end <= a.start
        };
        !apart(&self.columns, &other.columns) && !apart(&self.rows, &other.rows)
    }

    /// The tiles of a band of pixels (whose start is on a tile boundary).
    pub(crate) fn of_band(band: &Band) -> Self {
        Self {
            columns: band.columns.start / GROUP.width..band.columns.end.div_ceil(GROUP.width),
            rows: band.rows.start / GROUP.height..band.rows.end.div_ceil(GROUP.height),
        }
    }
}

/// A tile's cost: its row samples added.
fn tile_cost(samples: &[u32], tile: u32) -> u32 {
    let rows = GROUP.height as usize;
    samples[tile as usize * rows..(tile as usize + 1) * rows]
        .iter()
        .fold(0u32, |a, &c| a.saturating_add(c))
}

/// Cost classes: 0 for nothing, then four per octave (quarter-octave steps, ~19% apart).
pub(crate) const COST_CLASSES: usize = 1 + 32 * 4;

/// The class of a cost: tiles are ordered by class, which is as good a schedule as the
/// exact cost and lets the host sort in linear time (a comparison sort of 8,192 tiles took
/// 0.13 ms a frame on this project's 2-core machine).
pub(crate) fn cost_class(cost: u32) -> usize {
    if cost == 0 {
        return 0;
    }
    let octave = 31 - cost.leading_zeros();
    // The two bits after the leading one.
    let quarter = if octave >= 2 { (cost >> (octave - 2)) & 3 } else { (cost << (2 - octave)) & 3 };
    1 + (octave * 4 + quarter) as usize
}

/// Fill `order` for the tiles of `rect`: the dispatch slot that would trace tile `t` in row
/// order (`order[t]`, for each `t` in `rect`) gets the rect's tiles by falling
/// [`cost_class`], ties in row order. Entries outside `rect` are left alone. `costs` and
/// `order` hold one entry per tile of a frame `tiles_x` tiles wide.
#[cfg(test)]
pub(crate) fn order_costliest_first(
    costs: &[u32],
    order: &mut [u32],
    tiles_x: u32,
    rect: &TileRect,
) {
    let ranks = ranks(rect, |t| costs[t as usize], tiles_x);
    order_by_rank(&ranks, order, tiles_x, rect);
}

/// The rank of each of `rect`'s tiles in row order, 0 for the costliest class: what the
/// order of the rect depends on. `cost` gives a tile's cost by its index in the frame.
fn ranks(rect: &TileRect, cost: impl Fn(u32) -> u32, tiles_x: u32) -> Vec<u8> {
    let mut ranks = Vec::with_capacity(rect.columns.len() * rect.rows.len());
    for r in rect.rows.clone() {
        ranks.extend(
            rect.columns.clone().map(|c| (COST_CLASSES - cost_class(cost(r * tiles_x + c))) as u8),
        );
    }
    ranks
}

/// Fill `order` for the tiles of `rect` by their `ranks` (from [`ranks`]), lowest rank
/// first, ties in row order; entries outside `rect` are left alone.
fn order_by_rank(ranks: &[u8], order: &mut [u32], tiles_x: u32, rect: &TileRect) {
    // A counting sort: stable, so equal classes (a first frame's zeros) keep row order.
    let mut start = [0u32; COST_CLASSES + 1];
    for &rank in ranks {
        start[rank as usize] += 1;
    }
    let mut next = 0;
    for entry in start.iter_mut() {
        (*entry, next) = (next, next + *entry);
    }
    let mut sorted = vec![0u32; ranks.len()];
    let mut ranks = ranks.iter();
    for r in rect.rows.clone() {
        for c in rect.columns.clone() {
            let at = &mut start[*ranks.next().expect("one rank per tile") as usize];
            sorted[*at as usize] = r * tiles_x + c;
            *at += 1;
        }
    }
    // Dispatch slots in row order take the sorted tiles.
    let mut sorted = sorted.into_iter();
    for r in rect.rows.clone() {
        let row = (r * tiles_x) as usize;
        for slot in &mut order[row + rect.columns.start as usize..row + rect.columns.end as usize] {
            *slot = sorted.next().expect("one tile per slot");
        }
    }
}

/// A rect of a slot's order and the ranks it was last ordered by: while a frame's costs
/// give the same ranks (a still camera), its order stands and is not sorted again.
struct Ordered {
    rect: TileRect,
    ranks: Vec<u8>,
}

/// The tile order and cost record of every slot, at one resolution.
pub(crate) struct TileSchedule {
    tiles_x: u32,
    tiles: u32,
    /// Read by the shader: dispatch slot -> tile, `tiles` entries per slot (host-written).
    pub order: GpuBuffer,
    /// Written by the shader: one sample per row of each tile (`GROUP.height` per tile) in
    /// the slot's last frame (host-read).
    pub costs: GpuBuffer,
    /// Per slot, the rects whose order was written and the ranks it was written for
    /// (disjoint: the bands of a frame, the parts of a split frame).
    ordered: Vec<Vec<Ordered>>,
}

impl TileSchedule {
    /// Row order and no costs for `slots` slots of a `width` x `height` frame.
    pub(crate) fn new(
        ctx: &Arc<GpuContext>,
        width: u32,
        height: u32,
        slots: u32,
    ) -> Result<Self, GpuError> {
        let tiles_x = width.div_ceil(GROUP.width);
        let tiles = tiles_x * height.div_ceil(GROUP.height);
        let bytes = tiles as u64 * slots as u64 * 4;
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let mut order = GpuBuffer::new(ctx, bytes, usage, MemoryLocation::CpuToGpu, "tile order")?;
        let mut costs = GpuBuffer::new(
            ctx,
            bytes * GROUP.height as u64,
            usage,
            MemoryLocation::GpuToCpu,
            "tile costs",
        )?;
        let identity = (0..slots).flat_map(|_| 0..tiles);
        for (entry, tile) in
            order.mapped().expect("tile order is host-visible").chunks_exact_mut(4).zip(identity)
        {
            entry.copy_from_slice(&tile.to_le_bytes());
        }
        costs.mapped().expect("tile costs are host-visible").fill(0);
        Ok(Self { tiles_x, tiles, order, costs, ordered: (0..slots).map(|_| Vec::new()).collect() })
    }

    /// The first entry of `slot` in the order (the shader's `tile_base`).
    pub(crate) fn base(&self, slot: u32) -> u32 {
        slot * self.tiles
    }

    /// What each tile cost in `slot`'s last frame (its samples added), in row order. The
    /// slot's commands must be done (its fence waited for).
    #[cfg(test)]
    pub fn costs(&mut self, slot: u32) -> Vec<u32> {
        let tiles = self.tiles;
        let samples = self.samples(slot);
        (0..tiles).map(|t| tile_cost(samples, t)).collect()
    }

    /// The cost samples of `slot`'s last frame, `GROUP.height` per tile.
    fn samples(&mut self, slot: u32) -> &[u32] {
        let rows = GROUP.height as usize;
        let range = self.base(slot) as usize * rows..(self.base(slot) + self.tiles) as usize * rows;
        let bytes = self.costs.mapped().expect("tile costs are host-visible");
        &bytemuck::cast_slice(bytes)[range]
    }

    /// Order `rect`'s tiles for the next dispatch of `slot` by what they cost in its last
    /// frame; returns the slot's base. The slot's commands must be done. When the costs
    /// rank the tiles as they did for the order in place, that order stays: the sort and
    /// its writes were half of the ~0.08 ms this took per frame on the H100's host.
    pub(crate) fn order(&mut self, slot: u32, rect: &TileRect) -> u32 {
        let tiles_x = self.tiles_x;
        let samples = self.samples(slot);
        let ranks = ranks(rect, |t| tile_cost(samples, t), tiles_x);
        let unchanged =
            self.ordered[slot as usize].iter().any(|o| o.rect == *rect && o.ranks == ranks);
        if !unchanged {
            order_by_rank(&ranks, self.slot_order_mut(slot), tiles_x, rect);
            let ordered = &mut self.ordered[slot as usize];
            ordered.retain(|o| !o.rect.overlaps(rect));
            ordered.push(Ordered { rect: rect.clone(), ranks });
        }
        self.base(slot)
    }

    /// The order `slot`'s last dispatches took.
    #[cfg(test)]
    pub fn slot_order(&mut self, slot: u32) -> Vec<u32> {
        self.slot_order_mut(slot).to_vec()
    }

    fn slot_order_mut(&mut self, slot: u32) -> &mut [u32] {
        let range = self.base(slot) as usize..(self.base(slot) + self.tiles) as usize;
        let bytes = self.order.mapped().expect("tile order is host-visible");
        &mut bytemuck::cast_slice_mut(bytes)[range]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(columns: Range<u32>, rows: Range<u32>) -> TileRect {
        TileRect { columns, rows }
    }

    #[test]
    fn costliest_tiles_are_dispatched_first_and_ties_keep_row_order() {
        // 4 x 2 tiles; the costliest is the last in row order.
        let costs = [0, 5, 0, 1, 2, 0, 0, 9];
        let mut order = [u32::MAX; 8];
        order_costliest_first(&costs, &mut order, 4, &rect(0..4, 0..2));
        assert_eq!(order, [7, 1, 4, 3, 0, 2, 5, 6]);
    }

    #[test]
    fn a_rect_is_ordered_within_itself_and_nothing_else_is_touched() {
        // 5 x 3 tiles, the rect the middle three columns of the last two rows.
        let costs: Vec<u32> = (0..15).map(|t| (t * 7) % 11).collect();
        let mut order = vec![u32::MAX; 15];
        let r = rect(1..4, 1..3);
        order_costliest_first(&costs, &mut order, 5, &r);
        let inside: Vec<u32> = [6, 7, 8, 11, 12, 13].to_vec();
        for (t, &o) in order.iter().enumerate() {
            if inside.contains(&(t as u32)) {
                assert!(inside.contains(&o), "slot {t} got tile {o} from outside the rect");
            } else {
                assert_eq!(o, u32::MAX, "slot {t} outside the rect was written");
            }
        }
        // A permutation of the rect, in falling cost along the dispatch order.
        let dispatched: Vec<u32> = inside.iter().map(|&s| order[s as usize]).collect();
        let mut sorted = dispatched.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, inside);
        let class = |t: u32| cost_class(costs[t as usize]);
        assert!(
            dispatched
                .windows(2)
                .all(|w| class(w[0]) > class(w[1]) || (class(w[0]) == class(w[1]) && w[0] < w[1])),
            "{dispatched:?}"
        );
    }

    #[test]
    fn cost_classes_are_quarter_octaves_in_order() {
        assert_eq!([0, 1, 2, 3, 4, 5, 6, 7, 8].map(cost_class), [0, 1, 5, 7, 9, 10, 11, 12, 13]);
        assert_eq!(cost_class(u32::MAX), COST_CLASSES - 1);
        let classes: Vec<usize> = (0..100_000u32).map(cost_class).collect();
        assert!(classes.windows(2).all(|w| w[0] <= w[1]), "classes never fall as the cost grows");
        // Costs in one class are within a quarter octave.
        assert_eq!(cost_class(1000), cost_class(1023));
        assert!(cost_class(1000) < cost_class(1200));
    }

    #[test]
    fn empty_and_single_tile_rects() {
        let costs = [3u32, 1];
        let mut order = [9u32, 9];
        order_costliest_first(&costs, &mut order, 2, &rect(1..1, 0..1));
        assert_eq!(order, [9, 9]);
        order_costliest_first(&costs, &mut order, 2, &rect(1..2, 0..1));
        assert_eq!(order, [9, 1]);
    }

    mod on_the_gpu {
        use super::super::cost_class;
        use crate::gpu::dispatch::{FrameTrace, SplitTrace};
        use crate::gpu::trace_pass::Kernel;
        use crate::gpu::GROUP;
        use crate::gpu::{ComputeTracer, ContextOptions, GpuContext};
        use crate::render_settings::{Aov, RenderSettings};
        use crate::scene::paper::{paper_scene, prepare_mesh, LightOrbit};
        use crate::scene::primitives::PaperModel;
        use crate::tracer::{FrameParams, PackedScene};

        /// The paper's box around its torus knot, at a size that is no whole number of tiles.
        fn knot_in_the_box() -> (crate::scene::Scene, PackedScene) {
            let mut mesh = PaperModel::TorusKnot.mesh();
            prepare_mesh(&mut mesh);
            let scene = paper_scene(mesh, 1, LightOrbit::default());
            let packed = PackedScene::new(&scene);
            (scene, packed)
        }

        fn settings() -> RenderSettings {
            RenderSettings { width: 80, height: 42, bounces: 1, ..Default::default() }
        }

        #[test]
        fn tiles_record_their_cost_and_are_then_traced_costliest_first_to_the_same_pixels() {
            let ctx = GpuContext::new(&ContextOptions::validated())
                .expect("Vulkan with the validation layer");
            let (scene, packed) = knot_in_the_box();
            let params = FrameParams::new(&scene, settings());
            let mut tracer = ComputeTracer::with_scene(&ctx, &packed).unwrap();
            tracer.use_kernel(Kernel::Ours).unwrap();
            // The first frame has no costs yet: row order.
            let (first, _) = tracer.render(&params).unwrap();
            let (first_costs, row_order) = tracer.headless_tiles();
            assert!(row_order.iter().enumerate().all(|(i, &t)| t == i as u32), "{row_order:?}");
            // What each tile recorded is what the cost view counts over its pixels.
            let (cost, _) = tracer
                .render(&FrameParams::new(&scene, RenderSettings { aov: Aov::Cost, ..settings() }))
                .unwrap();
            let (costs, order) = tracer.headless_tiles();
            let tiles_x = 80u32.div_ceil(GROUP.width);
            // Each tile's rows sampled in their middle pixel (none past the frame's edge).
            let mut sums = vec![0u32; costs.len()];
            for (i, p) in cost.pixels.iter().enumerate() {
                let (x, y) = (i as u32 % 80, i as u32 / 80);
                if x % GROUP.width == GROUP.width / 2 {
                    sums[((y / GROUP.height) * tiles_x + x / GROUP.width) as usize] +=
                        (p[0] + p[1]) as u32;
                }
            }
            assert_eq!(costs, sums);
            assert!(
                costs.iter().any(|&c| c != costs[0]),
                "some tiles cost more than others: {costs:?}"
            );
            // The colour and the cost view count the same work; the second frame took the
            // tiles by the first one's, costliest first.
            assert_eq!(first_costs, costs);
            assert_ne!(order, row_order, "the order changed once costs were known");
            assert!(
                order
                    .windows(2)
                    .all(|w| cost_class(costs[w[0] as usize]) >= cost_class(costs[w[1] as usize])),
                "costliest first: {order:?}"
            );
            let (ordered, _) = tracer.render(&params).unwrap();
            assert_eq!(ordered.pixels, first.pixels, "the order changes no pixel");
            drop(tracer);
            let messages = ctx.validation_messages();
            assert!(messages.is_empty(), "validation: {messages:?}");
        }

        #[test]
        fn an_order_is_sorted_again_only_when_the_costs_rank_the_tiles_differently() {
            use super::super::{TileRect, TileSchedule};
            let ctx = GpuContext::new(&ContextOptions::validated())
                .expect("Vulkan with the validation layer");
            // 3 x 2 tiles, one slot.
            let mut tiles = TileSchedule::new(&ctx, GROUP.width * 3, GROUP.height * 2, 1).unwrap();
            let set_costs = |tiles: &mut TileSchedule, costs: [u32; 6]| {
                let samples: &mut [u32] = bytemuck::cast_slice_mut(tiles.costs.mapped().unwrap());
                for (t, c) in costs.iter().enumerate() {
                    samples[t * GROUP.height as usize] = *c;
                }
            };
            let whole = TileRect { columns: 0..3, rows: 0..2 };
            set_costs(&mut tiles, [1, 50, 3, 0, 9, 2]);
            tiles.order(0, &whole);
            assert_eq!(tiles.slot_order(0), [1, 4, 2, 5, 0, 3]);
            // The same ranks (costs within the same classes): the order in place stands.
            let marked = [5, 4, 3, 2, 1, 0];
            bytemuck::cast_slice_mut::<u8, u32>(tiles.order.mapped().unwrap())[..6]
                .copy_from_slice(&marked);
            set_costs(&mut tiles, [1, 51, 3, 0, 9, 2]);
            tiles.order(0, &whole);
            assert_eq!(tiles.slot_order(0), marked, "sorted again for the same ranks");
            // Another rect, or new ranks: sorted again.
            tiles.order(0, &TileRect { columns: 0..3, rows: 0..1 });
            assert_eq!(tiles.slot_order(0), [1, 2, 0, 2, 1, 0]);
            set_costs(&mut tiles, [100, 51, 3, 0, 9, 2]);
            tiles.order(0, &whole);
            assert_eq!(tiles.slot_order(0), [0, 1, 4, 2, 5, 3]);
            drop(tiles);
            let messages = ctx.validation_messages();
            assert!(messages.is_empty(), "validation: {messages:?}");
        }

        #[test]
        fn a_split_frame_is_the_same_in_tile_order_and_in_row_order() {
            let ctx = GpuContext::new(&ContextOptions::validated())
                .expect("Vulkan with the validation layer");
            let (scene, packed) = knot_in_the_box();
            let left = FrameParams::new(&scene, settings());
            let right =
                FrameParams::new(&scene, RenderSettings { bounces: 0, smooth: true, ..settings() });
            let frame = FrameTrace {
                params: left,
                split: Some(SplitTrace { column: GROUP.width, params: right }),
            };
            let mut images = Vec::new();
            for kernel in [Kernel::OursInRowOrder, Kernel::Ours] {
                let mut tracer = ComputeTracer::with_scene(&ctx, &packed).unwrap();
                tracer.use_kernel(kernel).unwrap();
                // Three frames: the last two ordered by the costs before them.
                let frames: Vec<_> =
                    (0..3).map(|_| tracer.render_frame(&frame).unwrap().0).collect();
                assert!(
                    frames.windows(2).all(|w| w[0].pixels == w[1].pixels),
                    "{kernel:?}: frames agree"
                );
                images.push(frames.into_iter().next().unwrap());
            }
            assert_eq!(images[0].pixels, images[1].pixels);
            let messages = ctx.validation_messages();
            assert!(messages.is_empty(), "validation: {messages:?}");
        }
    }

    #[test]
    fn rects_overlap_when_they_share_a_tile() {
        assert!(rect(0..2, 0..2).overlaps(&rect(1..3, 1..3)));
        assert!(!rect(0..2, 0..2).overlaps(&rect(2..4, 0..2)), "side by side");
        assert!(!rect(0..2, 0..2).overlaps(&rect(0..2, 2..3)), "one above the other");
        assert!(!rect(0..0, 0..2).overlaps(&rect(0..2, 0..2)), "an empty rect");
    }

    #[test]
    fn a_band_covers_the_tiles_its_pixels_touch() {
        let band = Band::rect(GROUP.height..GROUP.height * 3 + 1, GROUP.width..GROUP.width * 2 + 5);
        assert_eq!(TileRect::of_band(&band), rect(1..3, 1..4));
    }
}

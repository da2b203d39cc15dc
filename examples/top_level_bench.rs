//! How long the top level takes to rebuild: the instance records and the tree over their
//! boxes for fields of 100 to 10,000 copies (what a change of the model count or a moved
//! instance costs before the upload).
//!
//! `cargo run --release --example top_level_bench` prints, per count, the median and the
//! best of 21 rebuilds in milliseconds and the bytes per instance (records and tree).

use std::time::Instant;

use meshtracer::bvh::{BuildOptions, Bvh};
use meshtracer::scene::paper::{instances, paper_scene, prepare_mesh, LightOrbit};
use meshtracer::scene::primitives::PaperModel;
use meshtracer::tracer::PackedScene;

fn main() {
    let mut mesh = PaperModel::Geosphere.mesh();
    prepare_mesh(&mut mesh);
    let bounds = mesh.bounds();
    let mut packed = PackedScene::new(&paper_scene(mesh, 1, LightOrbit::default()));
    println!("copies  median ms  best ms  tree ms  bytes/instance  SAH cost");
    for count in [100, 1000, 10_000] {
        let list = instances(count, 1);
        let mut times: Vec<f64> = (0..21)
            .map(|_| {
                let start = Instant::now();
                packed.set_instances(&list);
                start.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        times.sort_by(f64::total_cmp);
        // The tree alone, over the same world boxes (the rest is the records).
        let boxes: Vec<_> = list.iter().map(|i| i.world_bounds(bounds)).collect();
        let options = BuildOptions::default();
        let tree = median_ms(|| drop(Bvh::build_named_leaves(&boxes, None, &options)));
        let per_instance = packed.top_level.bytes() as f64 / list.len() as f64;
        let sah = packed.top_level.sah_cost();
        println!(
            "{count:>6}  {:>9.3}  {:>7.3}  {tree:>7.3}  {per_instance:>14.1}  {sah:>8.1}",
            times[10], times[0]
        );
    }
}

/// The median of 21 runs of `work`, in milliseconds.
fn median_ms(mut work: impl FnMut()) -> f64 {
    let mut times: Vec<f64> = (0..21)
        .map(|_| {
            let start = Instant::now();
            work();
            start.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[10]
}

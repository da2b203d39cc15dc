//! BVH build speed: `Bvh::build` (binned SAH, 16 bins, leaves of at most 4 triangles,
//! parallel with rayon on all cores) over generated torus knots of 100k and 1M triangles.
//!
//! `cargo bench --bench bvh_build` (add `-- --quick` for a short run).

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::Vec3;
use meshtracer::bvh::{BuildOptions, Bvh};
use meshtracer::scene::primitives::large_torus_knot;

fn triangles(n: usize) -> Vec<[Vec3; 3]> {
    let mesh = large_torus_knot(n);
    (0..mesh.triangle_count()).map(|i| mesh.corners(i)).collect()
}

fn build(c: &mut Criterion) {
    let options = BuildOptions::default();
    let mut group = c.benchmark_group("bvh_build");
    group.sample_size(10).measurement_time(Duration::from_secs(10));
    for n in [100_000, 1_000_000] {
        let tris = triangles(n);
        group.throughput(Throughput::Elements(tris.len() as u64));
        group.bench_with_input(BenchmarkId::new("torus_knot", tris.len()), &tris, |b, tris| {
            b.iter(|| Bvh::build(black_box(tris), &options))
        });
    }
    group.finish();
}

criterion_group!(benches, build);
criterion_main!(benches);

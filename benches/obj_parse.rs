//! OBJ parsing speed: a generated torus knot of ~100k triangles (positions, normals, `f
//! a//a` faces), written once to text and parsed from memory on each iteration.
//!
//! `cargo bench --bench obj_parse` (add `-- --quick` for a short run).

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use meshtracer::scene::obj::load_obj_from_str;
use meshtracer::scene::primitives::{large_torus_knot, write_obj};

/// The OBJ text of a torus knot with at least `triangles` triangles, and its exact count.
fn obj_text(triangles: usize) -> (String, usize) {
    let mesh = large_torus_knot(triangles);
    let path = std::env::temp_dir().join(format!("meshtracer-bench-{}-{triangles}.obj", std::process::id()));
    write_obj(&mesh, &path).expect("write the OBJ");
    let text = std::fs::read_to_string(&path).expect("read the OBJ back");
    let _ = std::fs::remove_file(&path);
    (text, mesh.triangle_count())
}

fn parse(c: &mut Criterion) {
    let mut group = c.benchmark_group("obj_parse");
    group.sample_size(20).measurement_time(Duration::from_secs(15));
    let (text, triangles) = obj_text(100_000);
    group.throughput(Throughput::Bytes(text.len() as u64));
    group.bench_with_input(BenchmarkId::new("torus_knot", triangles), &text, |b, text| {
        b.iter(|| {
            let loaded = load_obj_from_str(black_box(text), "bench.obj", None).expect("parse");
            assert_eq!(loaded.mesh.triangle_count(), triangles);
            loaded
        })
    });
    group.finish();
}

criterion_group!(benches, parse);
criterion_main!(benches);

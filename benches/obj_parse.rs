//! OBJ parsing speed: a generated torus knot of ~100k and ~1M triangles (positions,
//! normals, `f a//a` faces), written once to text and parsed from memory on each
//! iteration: the parallel loader, the same in one chunk (one thread), and the serial tobj
//! loader it replaced.
//!
//! `cargo bench --bench obj_parse` (add `-- --quick` for a short run).
//!
//! With `OBJ_FILE=path` set, the bench binary instead loads that file once, as the
//! program does (`load_obj`: read, parse, text freed, mesh built), and prints the time and
//! MB/s; `OBJ_LOADER=tobj` loads it through the serial tobj loader instead (the file read
//! whole, then parsed). Run it under `/usr/bin/time -f "%e s %M KB"` for the peak memory.

use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};

use criterion::{criterion_group, BenchmarkId, Criterion, Throughput};
use meshtracer::scene::obj::{
    load_obj, load_obj_from_str, load_obj_from_str_chunked, load_obj_from_str_tobj, LoadOptions,
};
use meshtracer::scene::primitives::{large_torus_knot, write_obj};

/// The OBJ text of a torus knot with at least `triangles` triangles, and its exact count.
fn obj_text(triangles: usize) -> (String, usize) {
    let mesh = large_torus_knot(triangles);
    let path = std::env::temp_dir()
        .join(format!("meshtracer-bench-{}-{triangles}.obj", std::process::id()));
    write_obj(&mesh, &path).expect("write the OBJ");
    let text = std::fs::read_to_string(&path).expect("read the OBJ back");
    let _ = std::fs::remove_file(&path);
    (text, mesh.triangle_count())
}

fn parse(c: &mut Criterion) {
    let mut group = c.benchmark_group("obj_parse");
    group.sample_size(10).measurement_time(Duration::from_secs(10));
    for size in [100_000, 1_000_000] {
        let (text, triangles) = obj_text(size);
        group.throughput(Throughput::Bytes(text.len() as u64));
        type Loader = fn(&str) -> meshtracer::scene::obj::LoadedObj;
        let loaders: [(&str, Loader); 3] = [
            ("parallel", |t| load_obj_from_str(t, "bench.obj", None).expect("parse")),
            ("one_chunk", |t| {
                load_obj_from_str_chunked(t, "bench.obj", None, &LoadOptions::default(), usize::MAX)
                    .expect("parse")
            }),
            ("tobj", |t| {
                load_obj_from_str_tobj(t, "bench.obj", None, &LoadOptions::default())
                    .expect("parse")
            }),
        ];
        for (name, load) in loaders {
            group.bench_with_input(BenchmarkId::new(name, triangles), &text, |b, text| {
                b.iter(|| {
                    let loaded = load(black_box(text));
                    assert_eq!(loaded.mesh.triangle_count(), triangles);
                    loaded
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, parse);

/// Load `OBJ_FILE` once and report, or run the benchmarks.
fn main() {
    let Some(file) = std::env::var_os("OBJ_FILE") else {
        benches();
        Criterion::default().configure_from_args().final_summary();
        return;
    };
    let path = Path::new(&file);
    let bytes = std::fs::metadata(path).expect("OBJ_FILE names a file").len();
    let tobj = std::env::var("OBJ_LOADER").is_ok_and(|l| l == "tobj");
    let start = Instant::now();
    let loaded = if tobj {
        let text = std::fs::read_to_string(path).expect("read OBJ_FILE");
        load_obj_from_str_tobj(
            &text,
            &path.display().to_string(),
            path.parent(),
            &LoadOptions::default(),
        )
    } else {
        load_obj(path)
    };
    let seconds = start.elapsed().as_secs_f64();
    let mesh = loaded.expect("OBJ_FILE loads").mesh;
    println!(
        "{} ({}): {:.1} MB in {seconds:.3} s = {:.0} MB/s; {} triangles, {} vertices",
        path.display(),
        if tobj { "tobj" } else { "parallel" },
        bytes as f64 / 1e6,
        bytes as f64 / 1e6 / seconds,
        mesh.triangle_count(),
        mesh.vertex_count()
    );
}

//! How long the model files named on the command line take to parse from memory (the read
//! is not counted): each file parsed `RUNS` times (default 5), the fastest and the median
//! printed. PLY files are parsed twice over: as the program does (on every core) and by the
//! plain serial reader alone, the oracle the parallel readers are held to.
//!
//! `cargo run --release --example parse_timings -- a.ply b.obj ...`; `WAY=serial` or
//! `WAY=parallel` times one of the PLY readers alone (for a profiler). OBJ files are also
//! timed as `load` (`load_obj`: the read counted too, as rapidobj's timings count it).
//! `RUST_LOG=meshtracer=debug` logs the steps of each load.

use std::path::Path;
use std::time::Instant;

use meshtracer::scene::obj::{load_obj, load_obj_from_bytes, LoadOptions};
use meshtracer::scene::ply::load_ply_from_bytes_chunked;

/// A way to parse the file: its name, and a parse giving the triangle count.
type Way<'a> = (&'static str, Box<dyn FnMut() -> usize + 'a>);

/// The fastest and the median of `runs` timings of `f`, in ms, and the triangle count.
fn time(runs: usize, mut f: impl FnMut() -> usize) -> (f64, f64, usize) {
    let mut ms = Vec::new();
    let mut triangles = 0;
    for _ in 0..runs {
        let start = Instant::now();
        triangles = f();
        ms.push(start.elapsed().as_secs_f64() * 1e3);
    }
    ms.sort_by(f64::total_cmp);
    (ms[0], ms[ms.len() / 2], triangles)
}

fn main() -> anyhow::Result<()> {
    // `RUST_LOG=meshtracer=debug` adds the loaders' own steps.
    env_logger::init();
    let runs: usize = std::env::var("RUNS").ok().and_then(|r| r.parse().ok()).unwrap_or(5);
    println!("{} threads", rayon::current_num_threads());
    for path in std::env::args().skip(1) {
        let bytes = std::fs::read(&path)?;
        let mb = bytes.len() as f64 / 1e6;
        let mut ways: Vec<Way> = Vec::new();
        if path.ends_with(".ply") {
            ways.push(("parallel", Box::new(|| ply(&bytes, &path, Some(256 << 10)))));
            ways.push(("serial", Box::new(|| ply(&bytes, &path, None))));
        } else {
            // The loader takes the text and frees it: a copy a run, made before the clock starts.
            let mut copies: Vec<Vec<u8>> = (0..runs).map(|_| bytes.clone()).collect();
            let name = path.clone();
            ways.push((
                "parallel",
                Box::new(move || {
                    let text = copies.pop().unwrap_or_default();
                    let dir = Path::new(&name).parent();
                    let loaded = load_obj_from_bytes(text, &name, dir, &LoadOptions::default());
                    loaded.expect("the OBJ loads").mesh.triangle_count()
                }),
            ));
            let file = path.clone();
            ways.push((
                "load",
                Box::new(move || {
                    let loaded = load_obj(Path::new(&file));
                    loaded.expect("the OBJ loads").mesh.triangle_count()
                }),
            ));
        }
        let only = std::env::var("WAY").ok();
        ways.retain(|(way, _)| only.as_deref().is_none_or(|o| o == *way));
        for (way, f) in &mut ways {
            let (best, median, triangles) = time(runs, f);
            println!("{path} ({mb:.1} MB, {triangles} triangles) {way}: best {best:.1} ms, median {median:.1} ms, {:.0} MB/s", mb / best * 1e3);
        }
    }
    Ok(())
}

fn ply(bytes: &[u8], name: &str, chunk: Option<usize>) -> usize {
    let loaded = load_ply_from_bytes_chunked(bytes, name, chunk).expect("the PLY loads");
    loaded.mesh.triangle_count()
}

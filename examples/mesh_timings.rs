//! How long meshes take to reach the tracer: the `torusknot:N` generator at 1M, 4M and 10M
//! triangles, and the OBJ loader on the files named on the command line.
//!
//! `cargo run --release --example mesh_timings -- [a.obj b.obj ...]`

use std::path::Path;
use std::time::Instant;

use meshtracer::scene::obj::load_obj;
use meshtracer::scene::primitives::large_torus_knot;

fn main() -> anyhow::Result<()> {
    for million in [1, 4, 10] {
        let start = Instant::now();
        let mesh = large_torus_knot(million * 1_000_000);
        let ms = start.elapsed().as_secs_f64() * 1e3;
        println!(
            "{}: {} vertices, {} triangles generated in {ms:.0} ms",
            mesh.name,
            mesh.vertex_count(),
            mesh.triangle_count()
        );
    }
    for path in std::env::args().skip(1) {
        let start = Instant::now();
        let loaded = load_obj(Path::new(&path))?;
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let m = &loaded.mesh;
        println!(
            "{path}: {} vertices, {} triangles, {} materials, file normals {}, texcoords {}, loaded in {ms:.1} ms, {} warnings",
            m.vertex_count(),
            m.triangle_count(),
            m.materials.len(),
            m.has_file_normals,
            !m.texcoords.is_empty(),
            loaded.warnings.len()
        );
        for w in &loaded.warnings {
            println!("  warning: {w}");
        }
    }
    Ok(())
}

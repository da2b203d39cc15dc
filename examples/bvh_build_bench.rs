//! BVH build benchmark: our binned-SAH builder against `obvhs` (PLOC + reinsertion) on
//! random triangle soups, a tessellated torus and optional OBJ files.
//!
//! `cargo run --release --example bvh_build_bench -- [triangle counts | .obj paths]`
//! (default: 100000 1000000 4000000; counts may end in k or M: `1M`). Each count runs a
//! random soup, a torus and `scene::primitives::large_torus_knot`.
//!
//! For each mesh and builder it prints the best wall time of a few builds and the least CPU
//! time (all threads; the steadier number on a shared machine), the SAH cost under our cost
//! model (obvhs' tree is converted to our node layout, so the same `sah_cost` and the same
//! CPU traversal measure both), the depth and leaf count, and the average number of nodes
//! visited and triangles tested by our traversal per ray (100k rays at random surface points).
//!
//! Environment knobs: `BENCH_RUNS` (builds per measurement), `BENCH_BINS` and `BENCH_LEAF`
//! (our options), `BENCH_ONLY_OURS` (skip obvhs), `BENCH_QUICK` (timings only),
//! `BENCH_KNOT_ONLY` (counts run the knot alone), `BENCH_PHASES` (also print where our
//! build's time went, phase by phase, from its fastest run), `BENCH_WIDE` (also collapse our
//! tree into the wide one and count its traversal over the same rays: collapse time, depth,
//! nodes, per-ray work, the longest path and the stack entries it can need).

use std::time::{Duration, Instant};

use glam::Vec3;
use meshtracer::bvh::{
    ordered_edges, BuildOptions, Bvh, BvhChild, BvhNode, TraversalStats, STACK_SIZE,
};
use meshtracer::geometry::{Aabb, Ray};
use obvhs::{bvh2::builder::build_bvh2_from_tris, bvh2::Bvh2, triangle::Triangle, BvhBuildParams};
use rayon::prelude::*;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let args = if args.is_empty() {
        vec!["100000".into(), "1000000".into(), "4000000".into()]
    } else {
        args
    };
    println!("threads: {}", rayon::current_num_threads());
    println!(
        "{:<28} {:<26} {:>10} {:>8} {:>9} {:>6} {:>9} {:>8} {:>8}",
        "mesh", "builder", "build ms", "cpu ms", "SAH", "depth", "leaves", "nodes/r", "tris/r"
    );
    for arg in &args {
        if let Some(n) = count(arg) {
            if std::env::var_os("BENCH_KNOT_ONLY").is_none() {
                bench(&format!("random soup {n}"), &random_soup(n, 0x9e3779b97f4a7c15));
                bench(&format!("torus {n}"), &torus(n));
            }
            let knot = meshtracer::scene::primitives::large_torus_knot(n);
            bench(&format!("torus knot {n}"), &corners(&knot));
        } else {
            match meshtracer::scene::obj::load_obj(std::path::Path::new(arg)) {
                Ok(obj) => bench(arg, &corners(&obj.mesh)),
                Err(e) => eprintln!("skipping {arg}: {e}"),
            }
        }
    }
}

/// A triangle count such as `1000000`, `1_000_000`, `250k` or `1M`.
fn count(arg: &str) -> Option<usize> {
    let arg = arg.replace('_', "");
    let (digits, scale) = match arg.strip_suffix(['k', 'K']) {
        Some(d) => (d, 1_000),
        None => arg.strip_suffix('M').map_or((arg.as_str(), 1), |d| (d, 1_000_000)),
    };
    digits.parse::<usize>().ok().map(|n| n * scale)
}

fn bench(name: &str, tris: &[[Vec3; 3]]) {
    if tris.is_empty() {
        return;
    }
    let name = format!("{name} ({}k)", tris.len() / 1000);
    let mut options = BuildOptions::default();
    options.bins = env("BENCH_BINS").unwrap_or(options.bins);
    options.max_leaf_size = env("BENCH_LEAF").unwrap_or(options.max_leaf_size);
    let runs = env("BENCH_RUNS").unwrap_or(if tris.len() > 2_000_000 { 3 } else { 5 });
    let only_ours = std::env::var_os("BENCH_ONLY_OURS").is_some();
    let rays =
        if std::env::var_os("BENCH_QUICK").is_some() { vec![] } else { probe_rays(tris, 100_000) };

    let ((ours, phases), t) = best_of(runs, || Bvh::build_timed(tris, &options));
    report(&name, "ours (binned SAH)", t, &ours, tris, &rays);
    if std::env::var_os("BENCH_WIDE").is_some() {
        wide_report(&name, &ours, tris, &rays);
    }
    if std::env::var_os("BENCH_PHASES").is_some() {
        let list: Vec<String> =
            phases.iter().map(|(p, d)| format!("{p} {:.1}", d.as_secs_f64() * 1e3)).collect();
        println!("  phases (ms): {}", list.join(", "));
    }

    let otris: Vec<Triangle> = tris
        .iter()
        .map(|t| bytemuck::cast::<[[f32; 4]; 3], Triangle>(t.map(|v| v.extend(0.0).to_array())))
        .collect();
    let presets = [
        ("obvhs medium_build", BvhBuildParams::medium_build()),
        (
            "obvhs medium, leaf<=4",
            BvhBuildParams { max_prims_per_leaf: 4, ..BvhBuildParams::medium_build() },
        ),
        ("obvhs fast_build", BvhBuildParams::fast_build()),
    ];
    for (label, params) in presets.into_iter().filter(|_| !only_ours) {
        let (bvh2, t) =
            best_of(runs, || build_bvh2_from_tris(&otris, params, &mut Duration::default()));
        report(&name, label, t, &from_obvhs(&bvh2), tris, &rays);
    }
}

/// A number from the environment (`BENCH_RUNS`, `BENCH_BINS`, `BENCH_LEAF`).
fn env<T: std::str::FromStr>(key: &str) -> Option<T> {
    std::env::var(key).ok().and_then(|v| v.parse().ok())
}

/// Best wall time of `runs` calls (with that call's result), and the least CPU time (all
/// threads) of one call.
fn best_of<T>(runs: usize, mut f: impl FnMut() -> T) -> (T, Timing) {
    let mut best = Timing { wall: Duration::MAX, cpu: Duration::MAX };
    let mut result = None;
    for _ in 0..runs {
        let (start, cpu_start) = (Instant::now(), process_cpu_time());
        let r = f();
        let wall = start.elapsed();
        best.cpu = best.cpu.min(process_cpu_time().saturating_sub(cpu_start));
        if wall < best.wall {
            best.wall = wall;
            result = Some(r);
        }
    }
    (result.unwrap(), best)
}

struct Timing {
    wall: Duration,
    cpu: Duration,
}

/// User + system time of this process so far (Linux; zero elsewhere). On a shared machine the
/// CPU time is the steadier number; it is in clock ticks (10 ms).
fn process_cpu_time() -> Duration {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the ")" that ends the command name: utime and stime are the 12th and 13th.
    let fields: Vec<&str> = stat.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let ticks: u64 =
        fields.get(11..13).map_or(0, |f| f.iter().filter_map(|x| x.parse::<u64>().ok()).sum());
    Duration::from_millis(ticks * 10)
}

fn report(mesh: &str, builder: &str, t: Timing, bvh: &Bvh, tris: &[[Vec3; 3]], rays: &[Ray]) {
    if std::env::var_os("BENCH_QUICK").is_some() {
        println!(
            "{mesh:<28} {builder:<26} {:>10.1} {:>8.0}",
            t.wall.as_secs_f64() * 1e3,
            t.cpu.as_secs_f64() * 1e3
        );
        return;
    }
    let options = BuildOptions { max_leaf_size: 255, ..Default::default() };
    if let Err(e) = bvh.validate_with(tris, &options) {
        println!("{mesh:<28} {builder:<26} INVALID: {e}");
        return;
    }
    let (nodes, triangles) = if bvh.depth() <= STACK_SIZE {
        let ordered = ordered_edges(bvh, tris);
        let stats = rays
            .par_iter()
            .map(|ray| {
                let mut s = TraversalStats::default();
                bvh.closest_hit(&ordered, ray, 0.0, f32::INFINITY, &mut s);
                (s.nodes as u64, s.triangles as u64)
            })
            .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
        (
            format!("{:.1}", stats.0 as f64 / rays.len() as f64),
            format!("{:.1}", stats.1 as f64 / rays.len() as f64),
        )
    } else {
        ("(deep)".into(), "(deep)".into())
    };
    println!(
        "{mesh:<28} {builder:<26} {:>10.1} {:>8.0} {:>9.2} {:>6} {:>9} {nodes:>8} {triangles:>8}",
        t.wall.as_secs_f64() * 1e3,
        t.cpu.as_secs_f64() * 1e3,
        bvh.sah_cost(&BuildOptions::default()),
        bvh.depth(),
        bvh.leaf_count(),
    );
}

/// The wide tree collapsed from `bvh`: collapse time, depth, nodes, the mean nodes and
/// triangles per ray of its traversal, the longest path (nodes + triangles) and the stack need.
fn wide_report(mesh: &str, bvh: &Bvh, tris: &[[Vec3; 3]], rays: &[Ray]) {
    let mut bvh = bvh.clone();
    let start = Instant::now();
    let wide = meshtracer::bvh::wide::collapse(&mut bvh);
    let ms = start.elapsed().as_secs_f64() * 1e3;
    let ordered = ordered_edges(&bvh, tris);
    let (nodes, triangles, longest) = rays
        .par_iter()
        .map(|ray| {
            let mut s = TraversalStats::default();
            meshtracer::bvh::wide::closest_hit(
                &wide.nodes,
                &ordered,
                ray,
                0.0,
                f32::INFINITY,
                &mut s,
            );
            (s.nodes as u64, s.triangles as u64, (s.nodes + s.triangles) as u64)
        })
        .reduce(|| (0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2.max(b.2)));
    let r = rays.len().max(1) as f64;
    println!(
        "{mesh:<28} {:<26} {ms:>10.1} {:>8} {:>9} {:>6} {:>9} {:>8.1} {:>8.1}  longest {longest}, stack need {}, tree hash {:016x}",
        "wide (collapsed)",
        "",
        "",
        wide.depth(),
        wide.nodes.len(),
        nodes as f64 / r,
        triangles as f64 / r,
        wide.stack_need(),
        tree_hash(&wide.nodes, &bvh.prim_indices)
    );
}

/// A hash of the wide nodes and the triangle order: equal hashes, the same tree (to check
/// that a faster collapse makes the same one).
fn tree_hash(nodes: &[meshtracer::bvh::wide::WideNode], prim_indices: &[u32]) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    bytemuck::cast_slice::<_, u8>(nodes).hash(&mut h);
    prim_indices.hash(&mut h);
    h.finish()
}

/// obvhs' BVH2 (one box per node, children adjacent) in our layout (both child boxes in
/// the parent), depth-first; leaves keep their ranges into `primitive_indices`.
fn from_obvhs(b: &Bvh2) -> Bvh {
    let child = |i: usize| {
        let n = &b.nodes[i];
        let [min, max]: [[f32; 4]; 2] = bytemuck::cast(*n.aabb());
        let bounds = Aabb { min: Vec3::from_slice(&min), max: Vec3::from_slice(&max) };
        BvhChild { bounds, index: n.first_index, count: n.prim_count }
    };
    let prim_indices = b.primitive_indices.clone();
    if b.nodes[0].prim_count > 0 {
        return Bvh { nodes: vec![BvhNode::new(child(0), BvhChild::EMPTY)], prim_indices };
    }
    let mut nodes = Vec::new();
    // (obvhs inner node, our slot in its parent to patch: (node, side))
    let mut stack = vec![(0usize, None::<(usize, usize)>)];
    while let Some((i, patch)) = stack.pop() {
        let slot = nodes.len();
        if let Some((p, side)) = patch {
            let node: &mut BvhNode = &mut nodes[p];
            if side == 0 {
                node.left_index = slot as u32
            } else {
                node.right_index = slot as u32
            }
        }
        let first = b.nodes[i].first_index as usize;
        nodes.push(BvhNode::new(child(first), child(first + 1)));
        for side in [1, 0] {
            if b.nodes[first + side].prim_count == 0 {
                stack.push((first + side, Some((slot, side))));
            }
        }
    }
    Bvh { nodes, prim_indices }
}

// --- meshes -------------------------------------------------------------------------------

fn corners(mesh: &meshtracer::scene::Mesh) -> Vec<[Vec3; 3]> {
    (0..mesh.triangle_count()).map(|i| mesh.corners(i)).collect()
}

fn random_soup(n: usize, mut seed: u64) -> Vec<[Vec3; 3]> {
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32
    };
    // Triangles about as big as their share of the volume, like a dense soup.
    let size = 2.0 / (n as f32).cbrt();
    (0..n)
        .map(|_| {
            let c = Vec3::new(next(), next(), next()) * 2.0 - 1.0;
            let mut corner = || c + (Vec3::new(next(), next(), next()) - 0.5) * size;
            [corner(), corner(), corner()]
        })
        .collect()
}

/// A torus (R = 1, r = 0.35) tessellated into at least `n` triangles.
fn torus(n: usize) -> Vec<[Vec3; 3]> {
    let quads = n.div_ceil(2);
    let minor = ((quads as f32 * 0.35).sqrt().ceil() as usize).max(3);
    let major = quads.div_ceil(minor).max(3);
    let p = |i: usize, j: usize| {
        let (u, v) = (
            std::f32::consts::TAU * i as f32 / major as f32,
            std::f32::consts::TAU * j as f32 / minor as f32,
        );
        let ring = 1.0 + 0.35 * v.cos();
        Vec3::new(ring * u.cos(), 0.35 * v.sin(), ring * u.sin())
    };
    let mut tris = Vec::with_capacity(2 * major * minor);
    for i in 0..major {
        for j in 0..minor {
            let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    tris
}

/// Rays from a sphere around the mesh towards random points on random triangles.
fn probe_rays(tris: &[[Vec3; 3]], count: usize) -> Vec<Ray> {
    let bounds = tris.iter().fold(Aabb::EMPTY, |b, t| b.union(Aabb::from_points(t)));
    let radius = bounds.extent().length().max(1e-6);
    let mut s = 0x2545f4914f6cdd1du64;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..count)
        .map(|_| {
            let t = tris[(next() * tris.len() as f32) as usize % tris.len()];
            let target = (t[0] + t[1] + t[2]) / 3.0;
            let dir = (Vec3::new(next(), next(), next()) - 0.5).normalize_or(Vec3::Z);
            let origin = bounds.center() + dir * radius;
            Ray::new(origin, (target - origin).normalize_or(Vec3::Z))
        })
        .collect()
}

//! How much adaptive sampling saves against uniform supersampling at equal quality.
//!
//! `cargo run --release --example adaptive_savings -- [model] [size]`
//!
//! Reference: uniform 64 spp. For N in 2, 4, 8, 16 it renders uniform N spp and adaptive
//! N spp (N samples on edge pixels, 1 elsewhere), and prints each one's RMSE against the
//! reference and the camera samples it spent (from the `samples` AOV).

use meshtracer::gpu::{ComputeTracer, ContextOptions, GpuContext};
use meshtracer::render_settings::{Aov, RenderSettings};
use meshtracer::scene::formats::load_model;
use meshtracer::scene::obj::LoadOptions;
use meshtracer::scene::paper::{paper_scene, LightOrbit, ModelSource};
use meshtracer::tracer::{FrameParams, Image, PackedScene};

fn rmse(a: &Image, b: &Image) -> f64 {
    let sum: f64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| (0..3).map(|c| ((p[c] - q[c]) as f64).powi(2)).sum::<f64>())
        .sum();
    (sum / (a.pixels.len() * 3) as f64).sqrt()
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let model = ModelSource::parse(args.get(1).map_or("geosphere", |s| s.as_str()));
    let size: u32 = args.get(2).map_or(Ok(128), |s| s.parse())?;
    let loaded = load_model(&model, &LoadOptions::default(), None)?;
    let scene = paper_scene(loaded.into_mesh(), 1, LightOrbit::default());
    let packed = PackedScene::new(&scene);
    let ctx = GpuContext::new(&ContextOptions::default())?;
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed)?;
    let base = RenderSettings { width: size, height: size, ..RenderSettings::default() };
    let mut render = |s: RenderSettings| -> anyhow::Result<(Image, f64)> {
        let (img, t) = tracer.render(&FrameParams::new(&scene, s))?;
        Ok((img, t.gpu_ms.unwrap_or(t.wall_ms)))
    };
    let (reference, _) = render(RenderSettings { spp: 64, ..base })?;
    let pixels = (size * size) as f64;
    println!("{} on {}, {size}x{size}, reference 64 spp uniform", model.label(), ctx.info.name);
    println!(
        "{:>4} {:>12} {:>12} {:>10} {:>12} {:>12} {:>10}",
        "N", "uniform RMSE", "samples/px", "ms", "adaptive RMSE", "samples/px", "ms"
    );
    for n in [2, 4, 8, 16] {
        let (uniform, tu) = render(RenderSettings { spp: n, ..base })?;
        let (adaptive, ta) = render(RenderSettings { spp: n, adaptive: true, ..base })?;
        let (counts, _) =
            render(RenderSettings { spp: n, adaptive: true, aov: Aov::Samples, ..base })?;
        let spent: f64 = counts.pixels.iter().map(|p| p[0] as f64).sum::<f64>() / pixels;
        println!(
            "{n:>4} {:>12.5} {:>12.2} {tu:>10.2} {:>12.5} {spent:>12.2} {ta:>10.2}",
            rmse(&uniform, &reference),
            n as f64,
            rmse(&adaptive, &reference)
        );
    }
    let (one, t1) = render(base)?;
    println!("   1 {:>12.5} {:>12.2} {t1:>10.2}", rmse(&one, &reference), 1.0);
    Ok(())
}

//! Soak test: trace frames headless for a long time and check that resident memory and
//! GPU allocations stay flat.
//!
//! `cargo run --release --example soak -- --frames 20000 --size 64`
//!
//! The loop traces the paper's scene with `ComputeTracer`, and every `--every` frames changes
//! the model count (`set_instances`, 1..=27 copies) and the resolution (cycling through
//! `size`, `size/2`, `size*3/4+1`, `size/4+3`: the output buffers are reallocated) and also reads a
//! frame back (staging buffers come and go). Every `--report` frames it prints resident
//! memory (VmRSS from /proc/self/status), the allocator's live allocations, memory blocks
//! and bytes, and open file descriptors. After the warm-up (`--warmup` frames) the first
//! report is the baseline; at the end the program exits non-zero if resident memory grew
//! by more than `--rss-tolerance` percent over it, or if the allocation count, the block
//! count or the allocated bytes at a report ever exceeded the baseline's (reports fall at
//! the same point of the cycle, so a flat program reports identical figures).

use std::time::Instant;

use anyhow::{bail, Context};
use clap::Parser;
use meshtracer::gpu::buffer::GpuBuffer;
use meshtracer::gpu::{ComputeTracer, ContextOptions, GpuContext};
use meshtracer::render_settings::RenderSettings;
use meshtracer::scene::formats::load_model;
use meshtracer::scene::obj::LoadOptions;
use meshtracer::scene::paper::{instances, paper_scene, LightOrbit, ModelSource, MAX_MODELS};
use meshtracer::tracer::{FrameParams, PackedScene};

#[derive(Parser, Debug)]
#[command(about = "Trace frames for a long time; fail if memory or GPU allocations grow")]
struct Args {
    /// Frames to trace.
    #[arg(long, default_value_t = 20_000)]
    frames: u64,
    /// Largest image side in pixels.
    #[arg(long, default_value_t = 64)]
    size: u32,
    /// Change model count and resolution every this many frames.
    #[arg(long, default_value_t = 125)]
    every: u64,
    /// Print a report every this many frames (a multiple of 4 * --every keeps the
    /// reports at the same point of the resolution cycle).
    #[arg(long, default_value_t = 1000)]
    report: u64,
    /// Frames before the baseline report.
    #[arg(long, default_value_t = 2000)]
    warmup: u64,
    /// Allowed growth of resident memory after warm-up, in percent.
    #[arg(long, default_value_t = 10.0)]
    rss_tolerance: f64,
    /// Stop after this many seconds even if frames remain (0: no limit).
    #[arg(long, default_value_t = 0)]
    seconds: u64,
    /// Model: a paper model name or an .obj path.
    #[arg(long, default_value = "geosphere")]
    model: String,
    /// Run under the Khronos validation layer (with synchronization validation).
    #[arg(long)]
    validation: bool,
    /// Leak one GPU buffer and 1 MiB of host memory per phase on purpose, to show that
    /// the checks fail (the run must end non-zero).
    #[arg(long)]
    plant_leak: bool,
}

/// Resident memory of this process in KiB.
fn rss_kib() -> anyhow::Result<u64> {
    let status =
        std::fs::read_to_string("/proc/self/status").context("reading /proc/self/status")?;
    let line = status
        .lines()
        .find(|l| l.starts_with("VmRSS:"))
        .context("no VmRSS in /proc/self/status")?;
    line.split_whitespace().nth(1).context("malformed VmRSS")?.parse().context("malformed VmRSS")
}

fn open_fds() -> usize {
    std::fs::read_dir("/proc/self/fd").map_or(0, |d| d.count())
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Report {
    frame: u64,
    rss_kib: u64,
    allocations: usize,
    blocks: usize,
    allocated_bytes: u64,
    capacity_bytes: u64,
    fds: usize,
}

fn report(ctx: &GpuContext, frame: u64) -> anyhow::Result<Report> {
    let r = ctx.allocator().generate_report();
    Ok(Report {
        frame,
        rss_kib: rss_kib()?,
        allocations: r.allocations.len(),
        blocks: r.blocks.len(),
        allocated_bytes: r.total_allocated_bytes,
        capacity_bytes: r.total_capacity_bytes,
        fds: open_fds(),
    })
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    if args.size < 4 || args.every == 0 || args.report == 0 {
        bail!("--size must be at least 4, --every and --report at least 1");
    }
    let source = ModelSource::parse(&args.model);
    let loaded = load_model(&source, &LoadOptions::default(), None)?;
    let mut scene = paper_scene(loaded.into_mesh(), MAX_MODELS, LightOrbit::default());
    let mut packed = PackedScene::new(&scene);
    let options = ContextOptions {
        validation: args.validation,
        sync_validation: args.validation,
        ..Default::default()
    };
    let ctx = GpuContext::new(&options)?;
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed)?;
    let sizes = [args.size, args.size / 2, args.size * 3 / 4 + 1, args.size / 4 + 3];
    println!(
        "soak: {} frames of {} on {} ({}), sizes {:?}, model count and size change every {} frames",
        args.frames,
        source.label(),
        ctx.info.name,
        ctx.info.driver,
        sizes,
        args.every
    );
    println!(
        "{:>8} {:>9} {:>10} {:>6} {:>7} {:>12} {:>12} {:>4} {:>9}",
        "frame",
        "seconds",
        "RSS KiB",
        "allocs",
        "blocks",
        "alloc bytes",
        "capacity",
        "fds",
        "ms/frame"
    );

    let start = Instant::now();
    let mut last = (start, 0u64);
    let mut baseline: Option<Report> = None;
    let mut worst: Option<Report> = None;
    let mut failures = Vec::new();
    let mut frame = 0u64;
    let mut checksum = 0f64;
    while frame < args.frames {
        if args.seconds > 0 && start.elapsed().as_secs() >= args.seconds {
            println!("stopping after {} s (--seconds)", args.seconds);
            break;
        }
        let phase = frame / args.every;
        let models = 1 + (phase * 7 % MAX_MODELS as u64) as u32;
        let size = sizes[(phase % 4) as usize];
        if frame % args.every == 0 {
            if args.plant_leak {
                let usage = ash::vk::BufferUsageFlags::STORAGE_BUFFER;
                std::mem::forget(GpuBuffer::new(
                    &ctx,
                    4096,
                    usage,
                    gpu_allocator::MemoryLocation::GpuOnly,
                    "planted leak",
                )?);
                std::hint::black_box(Box::leak(vec![1u8; 1 << 20].into_boxed_slice()));
            }
            scene.instances = instances(models, 0);
            packed.set_instances(&scene.instances);
            tracer.set_instances(&packed.top_level)?;
        }
        let settings =
            RenderSettings { width: size, height: size, bounces: 2, ..RenderSettings::default() };
        let mut params = FrameParams::new(&scene, settings);
        params.light_position =
            LightOrbit { angle_deg: frame as f32 * 3.0, ..LightOrbit::default() }.position();
        tracer.trace(&params)?;
        frame += 1;
        if frame % args.every == 0 {
            // A read-back per phase: staging buffers are created and freed.
            let img = tracer.read_image()?;
            checksum += img.pixels.iter().map(|p| p[0] as f64).sum::<f64>();
        }
        if frame % args.report == 0 {
            let r = report(&ctx, frame)?;
            let ms = last.0.elapsed().as_secs_f64() * 1e3 / (frame - last.1) as f64;
            last = (Instant::now(), frame);
            println!(
                "{:>8} {:>9.1} {:>10} {:>6} {:>7} {:>12} {:>12} {:>4} {:>9.3}",
                r.frame,
                start.elapsed().as_secs_f64(),
                r.rss_kib,
                r.allocations,
                r.blocks,
                r.allocated_bytes,
                r.capacity_bytes,
                r.fds,
                ms
            );
            if frame >= args.warmup {
                match baseline {
                    None => baseline = Some(r),
                    Some(b) => {
                        if r.allocations > b.allocations
                            || r.blocks > b.blocks
                            || r.allocated_bytes > b.allocated_bytes
                            || r.fds > b.fds
                        {
                            failures.push(format!(
                                "frame {}: {} allocations in {} blocks ({} bytes), {} fds; baseline {} in {} ({} bytes), {} fds",
                                r.frame, r.allocations, r.blocks, r.allocated_bytes, r.fds, b.allocations, b.blocks, b.allocated_bytes, b.fds
                            ));
                        }
                        if worst.is_none_or(|w| r.rss_kib > w.rss_kib) {
                            worst = Some(r);
                        }
                    }
                }
            }
        }
    }
    drop(tracer);
    let messages = ctx.validation_messages();
    let elapsed = start.elapsed().as_secs_f64();
    println!(
        "traced {frame} frames in {elapsed:.1} s ({:.2} ms/frame; checksum {checksum:.1})",
        elapsed * 1e3 / frame.max(1) as f64
    );
    if args.validation {
        println!("validation messages: {}", messages.len());
        if let Some(m) = messages.first() {
            failures.push(format!("{} validation message(s), the first: {m}", messages.len()));
        }
    }
    let Some(b) = baseline else {
        bail!("no report after the warm-up of {} frames: run more --frames", args.warmup);
    };
    let end = report(&ctx, frame)?;
    println!(
        "after freeing the tracer: {} allocations, {} blocks, {} bytes",
        end.allocations, end.blocks, end.allocated_bytes
    );
    if end.allocations != 0 {
        failures.push(format!(
            "{} allocations still live after the tracer was dropped",
            end.allocations
        ));
    }
    let peak = worst.map_or(b.rss_kib, |w| w.rss_kib.max(b.rss_kib));
    let growth = (peak as f64 - b.rss_kib as f64) / b.rss_kib as f64 * 100.0;
    println!(
        "RSS: baseline {} KiB at frame {}, peak after it {} KiB ({growth:+.1}%), allowed {:+.1}%; allocations {} at baseline",
        b.rss_kib, b.frame, peak, args.rss_tolerance, b.allocations
    );
    if growth > args.rss_tolerance {
        failures.push(format!(
            "resident memory grew {growth:.1}% after warm-up (allowed {}%)",
            args.rss_tolerance
        ));
    }
    if !failures.is_empty() {
        for f in &failures {
            eprintln!("soak: FAIL: {f}");
        }
        std::process::exit(1);
    }
    println!("soak: OK: resident memory and GPU allocations stayed flat");
    Ok(())
}

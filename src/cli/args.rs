//! Flags shared by `view`, `render` and `bench`, with their ranges.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

use crate::scene::obj::LoadOptions;
use crate::scene::paper::{LightOrbit, ModelSource, MAX_MODELS};
use crate::scene::spec::{CameraSpec, SceneSpec};
use crate::scene::EnvironmentSource;
use crate::tracer::frame::{Accel, Aov, RenderSettings, MAX_BOUNCES, MAX_RESOLUTION, MAX_SPP};

/// meshtracer: a Vulkan compute-shader ray tracer for triangle meshes, after Kim & Shin's
/// "Mesh-based ray tracing system using Vulkan". With no command it opens the interactive
/// tool on the paper's scene: a model inside six mirror planes, lit by an orbiting light.
#[derive(Parser, Debug)]
#[command(name = "meshtracer", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
    #[command(flatten)]
    pub view: ViewArgs,
}

/// What to do.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Open the interactive tool (the default).
    View(ViewArgs),
    /// Render one frame headless and write it to a file.
    Render(RenderArgs),
    /// Measure frame times: the paper's tables (--paper) and scaling series (--scaling).
    Bench(super::bench::BenchArgs),
    /// List the Vulkan devices (for --device).
    Devices,
}

fn parse_unit(s: &str) -> Result<f32, String> {
    let v: f32 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if (0.0..=1.0).contains(&v) { Ok(v) } else { Err(format!("{s} is out of range (0..=1)")) }
}

fn parse_finite(s: &str) -> Result<f32, String> {
    let v: f32 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if v.is_finite() { Ok(v) } else { Err(format!("{s} is not a finite number")) }
}

/// The scene and frame: what `view`, `render` and `bench` share.
#[derive(Args, Debug, Clone)]
pub(crate) struct SceneArgs {
    /// Model: geosphere, torusknot, sphere, cylinder (the paper's four), torusknot:N (a
    /// generated knot of N triangles, e.g. torusknot:4M), or a path to an .obj file.
    #[arg(long, default_value = "geosphere")]
    pub model: String,
    /// For .obj files with neither normals nor smoothing groups: faces meeting at a corner
    /// share a computed normal only where they bend by less than DEG degrees (0..=180),
    /// keeping sharper edges hard under --smooth. Default: every edge is smoothed.
    #[arg(long, value_name = "DEG", value_parser = parse_crease_angle, allow_hyphen_values = true)]
    pub crease_angle: Option<f32>,
    /// Number of identical models, laid out along the axes as in the paper's Table 2.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=MAX_MODELS as i64))]
    pub models: u32,
    /// Image width in pixels.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_RESOLUTION as i64))]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_RESOLUTION as i64))]
    pub height: u32,
    /// Mirror bounces after the primary hit (the paper used 2).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64))]
    pub bounces: u32,
    /// Reflection blend ratio: 0 = no reflections, 1 = pure mirrors.
    #[arg(long, default_value_t = 0.5, value_parser = parse_unit)]
    pub blend: f32,
    /// Position of the light on its orbit, in degrees.
    #[arg(long, default_value_t = 45.0, value_parser = parse_finite)]
    pub light_angle: f32,
    /// Acceleration: bvh, or brute (the paper's every-ray-against-every-triangle).
    #[arg(long, default_value = "bvh")]
    pub accel: Accel,
    /// Vulkan device index (see `meshtracer devices`); default: the fastest kind present.
    #[arg(long)]
    pub device: Option<usize>,
    /// Smooth shading: interpolate vertex normals (the paper shades flat).
    #[arg(long)]
    pub smooth: bool,
    /// Ignore `map_Kd` textures (use the materials' Kd).
    #[arg(long)]
    pub no_textures: bool,
    /// Environment seen by rays that miss: none (black, the paper), sky (generated), or an
    /// equirectangular image (PNG, JPEG, HDR, EXR).
    #[arg(long, default_value = "none")]
    pub env: String,
    /// Jittered samples per pixel (anti-aliasing); 1 = one ray through the pixel centre.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=MAX_SPP as i64))]
    pub spp: u32,
    /// Spend the --spp samples only on pixels at edges (seen directly or in the mirrors), one elsewhere.
    #[arg(long)]
    pub adaptive: bool,
    /// Leave out the six mirror planes (to see an --env map around the model).
    #[arg(long)]
    pub no_box: bool,
    /// Camera position X,Y,Z (the model sits at the origin with radius 1, the box reaches ±4).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<glam::Vec3>,
    /// Point the camera looks at, X,Y,Z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub target: Option<glam::Vec3>,
    /// Vertical field of view in degrees.
    #[arg(long, value_parser = parse_fov)]
    pub fov: Option<f32>,
}

fn parse_crease_angle(s: &str) -> Result<f32, String> {
    let v = parse_finite(s)?;
    if (0.0..=180.0).contains(&v) { Ok(v) } else { Err(format!("{s} is out of range (0..=180 degrees)")) }
}

fn parse_vec3(s: &str) -> Result<glam::Vec3, String> {
    crate::scene::camera::parse_point(s)
}

fn parse_fov(s: &str) -> Result<f32, String> {
    let v = parse_finite(s)?;
    if v > 1.0 && v < 179.0 { Ok(v) } else { Err(format!("{s} is out of range (1..179 degrees)")) }
}

impl SceneArgs {
    /// The scene spec these flags describe, writing `aov`.
    pub(crate) fn spec(&self, aov: Aov) -> SceneSpec {
        SceneSpec {
            model: ModelSource::parse(&self.model),
            load_options: LoadOptions { crease_angle: self.crease_angle },
            models: self.models,
            mirror_box: !self.no_box,
            light: LightOrbit { angle_deg: self.light_angle, ..LightOrbit::default() },
            camera: CameraSpec { eye: self.eye, target: self.target, fov: self.fov, framed: false },
            environment: EnvironmentSource::parse(&self.env),
            settings: RenderSettings {
                width: self.width,
                height: self.height,
                bounces: self.bounces,
                blend: self.blend,
                accel: self.accel,
                aov,
                smooth: self.smooth,
                textures: !self.no_textures,
                spp: self.spp,
                adaptive: self.adaptive,
            },
        }
    }
}

/// `meshtracer view`.
#[derive(Args, Debug, Clone)]
pub struct ViewArgs {
    #[command(flatten)]
    pub(crate) scene: SceneArgs,
    /// Quit after this many frames (for scripts and tests).
    #[arg(long)]
    pub(crate) frames: Option<u64>,
    /// Write the traced image (render resolution) to this PNG at exit.
    #[arg(long)]
    pub(crate) screenshot: Option<PathBuf>,
    /// Write the window as seen, panel included, to this PNG at exit.
    #[arg(long)]
    pub(crate) screenshot_ui: Option<PathBuf>,
    /// Initial window size as WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x800")]
    pub(crate) window: String,
    /// Turn on the Vulkan validation layer (also MESHTRACER_VALIDATION=1).
    #[arg(long)]
    pub(crate) validation: bool,
    /// Start with the numbers over the image hidden (the I key shows them).
    #[arg(long)]
    pub(crate) no_hud: bool,
}

impl ViewArgs {
    /// The tool's options: the CLI sits on top of the app, not the other way round.
    pub fn options(&self) -> anyhow::Result<crate::app::ViewOptions> {
        let window = crate::app::parse_window_size(&self.window).map_err(anyhow::Error::msg)?;
        Ok(crate::app::ViewOptions {
            spec: self.scene.spec(Aov::Color),
            device: self.scene.device,
            frames: self.frames,
            screenshot: self.screenshot.clone(),
            screenshot_ui: self.screenshot_ui.clone(),
            window,
            validation: self.validation,
            hud: !self.no_hud,
        })
    }
}

/// `meshtracer render`.
#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    #[command(flatten)]
    pub(crate) scene: SceneArgs,
    /// Trace on the CPU reference tracer instead of the GPU.
    #[arg(long)]
    pub(crate) cpu: bool,
    /// What to write: color (PNG), or depth, normal, prim-id, cost, samples (32-bit float
    /// OpenEXR; cost and samples also as a heat-map PNG).
    #[arg(long, default_value = "color")]
    pub(crate) aov: Aov,
    /// Output file (.png for color, .exr for the other AOVs).
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    /// Turn on the Vulkan validation layer (also MESHTRACER_VALIDATION=1).
    #[arg(long)]
    pub(crate) validation: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn render_args(extra: &[&str]) -> Result<RenderArgs, clap::Error> {
        let cli = Cli::try_parse_from(["meshtracer", "render", "-o", "out.png"].iter().chain(extra))?;
        match cli.command {
            Some(Command::Render(args)) => Ok(args),
            other => panic!("not a render command: {other:?}"),
        }
    }

    #[test]
    fn crease_angle_reaches_the_spec_and_is_checked() {
        assert_eq!(render_args(&[]).unwrap().scene.spec(Aov::Color).load_options.crease_angle, None);
        let args = render_args(&["--crease-angle", "30"]).unwrap();
        assert_eq!(args.scene.spec(Aov::Color).load_options, LoadOptions { crease_angle: Some(30.0) });
        for bad in ["-1", "180.5", "nan", "sharp"] {
            let e = render_args(&["--crease-angle", bad]).unwrap_err().to_string();
            assert!(e.contains("--crease-angle") && e.contains(bad), "{bad}: {e}");
        }
    }
}

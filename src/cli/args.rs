//! Flags shared by `view`, `render` and `bench`, with their ranges.

use std::collections::HashSet;
use std::path::PathBuf;

use clap::Args;

use crate::render_settings::{self as knobs, Accel, Aov, BvhLayout};
use crate::scene::obj::LoadOptions;
use crate::scene::paper::ModelSource;
use crate::scene::preset::{self, Loaded};
use crate::scene::spec::SceneSpec;
use crate::scene::EnvironmentSource;
use crate::tracer::packed::BvhBuilder;

/// The default scene spec: where every flag's default comes from, so none is restated.
pub(crate) fn defaults() -> SceneSpec {
    SceneSpec::default()
}

/// clap's parser of whole numbers in `range`, its errors naming the range as clap does.
pub(crate) fn ranged(range: knobs::Range) -> clap::builder::RangedI64ValueParser<u32> {
    clap::value_parser!(u32).range(range.i64s())
}

fn parse_unit(s: &str) -> Result<f32, String> {
    let v: f32 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    knobs::BLEND.check(v as f64, s).map(|()| v)
}

fn parse_finite(s: &str) -> Result<f32, String> {
    let v: f32 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{s} is not a finite number"))
    }
}

/// The scene and frame: what `view`, `render` and `bench` share.
#[derive(Args, Debug, Clone)]
pub(crate) struct SceneArgs {
    /// Model: geosphere, torusknot, sphere, cylinder (the paper's four), torusknot:N (a
    /// generated knot of N triangles, e.g. torusknot:4M), or a path to an OBJ, PLY or glTF
    /// (.gltf/.glb) file.
    #[arg(long, default_value_t = defaults().model.label())]
    pub model: String,
    /// For .obj files with neither normals nor smoothing groups: faces meeting at a corner
    /// share a computed normal only where they bend by less than DEG degrees (0..=180),
    /// keeping sharper edges hard under --smooth. Default: every edge is smoothed.
    #[arg(long, value_name = "DEG", value_parser = parse_crease_angle, allow_hyphen_values = true)]
    pub crease_angle: Option<f32>,
    /// Number of copies of the model (1..=10000): along the axes as in the paper's Table 2
    /// up to 27, then a growing field (the mirror box grows to hold it).
    #[arg(long, default_value_t = defaults().models, value_parser = ranged(knobs::MODELS), allow_negative_numbers = true)]
    pub models: u32,
    /// Turn and scale each copy at random, from this seed (0: identical copies, the paper's).
    #[arg(long, value_name = "SEED", default_value_t = defaults().scatter)]
    pub scatter: u32,
    /// Image width in pixels.
    #[arg(long, default_value_t = defaults().settings.width, value_parser = ranged(knobs::RESOLUTION), allow_negative_numbers = true)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = defaults().settings.height, value_parser = ranged(knobs::RESOLUTION), allow_negative_numbers = true)]
    pub height: u32,
    /// Mirror bounces after the primary hit (the paper used 2).
    #[arg(long, default_value_t = defaults().settings.bounces, value_parser = ranged(knobs::BOUNCES), allow_negative_numbers = true)]
    pub bounces: u32,
    /// Reflection blend ratio: 0 = no reflections, 1 = pure mirrors.
    #[arg(long, default_value_t = defaults().settings.blend, value_parser = parse_unit, allow_negative_numbers = true)]
    pub blend: f32,
    /// Position of the light on its orbit, in degrees.
    #[arg(long, default_value_t = defaults().light.angle_deg, value_parser = parse_finite, allow_negative_numbers = true)]
    pub light_angle: f32,
    /// Acceleration: bvh, brute (the paper's every-ray-against-every-triangle), or vendor
    /// (the GPU driver's own acceleration structures and traversal, Vulkan ray tracing).
    #[arg(long, default_value_t = defaults().settings.accel)]
    pub accel: Accel,
    /// BVH layout with --accel bvh: wide (the compressed eight-wide tree of Ylitie, Karras
    /// and Laine 2017; the fastest on every framed and mirror-box row measured), binary (two
    /// children per node; builds in half the time) or wide-runs (the wide tree, each ray
    /// testing its pending leaves back to back: faster where rays meet runs of leaves);
    /// `view` also takes auto (time each on the model shown, keep the fastest), which is
    /// what it does without the flag unless scripted.
    #[arg(long, default_value_t = BvhChoice::Layout(defaults().settings.bvh))]
    pub bvh: BvhChoice,
    /// Vulkan device index (see `meshtracer devices`); default: the fastest kind present.
    #[arg(long)]
    pub device: Option<usize>,
    /// Where the BVH is built: cpu (binned SAH, the best trees), device (a linear BVH on the
    /// GPU, in place after the upload: tens of milliseconds where the CPU takes seconds, but
    /// slower to trace, and binary only) or auto (the device for meshes of 50M triangles
    /// and more).
    #[arg(long, value_name = "WHERE", default_value_t = BvhBuilder::Auto)]
    pub bvh_build: BvhBuilder,
    /// Smooth shading: interpolate vertex normals (the paper shades flat).
    #[arg(long)]
    pub smooth: bool,
    /// Ignore `map_Kd` textures and vertex colours (use the materials' Kd).
    #[arg(long)]
    pub no_textures: bool,
    /// Environment seen by rays that miss: none (black, the paper), sky (generated), or an
    /// equirectangular image (PNG, JPEG, HDR, EXR).
    #[arg(long, default_value = "none")]
    pub env: String,
    /// Jittered samples per pixel (anti-aliasing); 1 = one ray through the pixel centre.
    #[arg(long, default_value_t = defaults().settings.spp, value_parser = ranged(knobs::SPP), allow_negative_numbers = true)]
    pub spp: u32,
    /// Spend the --spp samples only on pixels at edges (seen directly or in the mirrors), one elsewhere.
    #[arg(long)]
    pub adaptive: bool,
    /// The AO view (--aov ao, the window's ambient-occlusion view): occlusion rays per
    /// primary hit and frame, cosine-weighted around the normal (1..=256).
    #[arg(long, value_name = "N", default_value_t = defaults().settings.ao_samples, value_parser = ranged(knobs::AO_SAMPLES), allow_negative_numbers = true)]
    pub ao_samples: u32,
    /// The AO view: how far an occlusion ray looks, in scene units (every model is scaled
    /// to radius 1, the mirror box reaches 4), above 0 and below 1000.
    #[arg(long, value_name = "R", default_value_t = defaults().settings.ao_radius, value_parser = |s: &str| knobs::AO_RADIUS.parse_f32(s), allow_negative_numbers = true)]
    pub ao_radius: f32,
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
    /// Start from a preset: a TOML preset file, or a PNG this program wrote (it carries
    /// its preset). Flags given beside it override it.
    #[arg(long, value_name = "FILE")]
    pub(crate) preset: Option<PathBuf>,
    /// The flags given on the command line (clap's ids); None: all of them count as given.
    #[arg(skip)]
    pub(crate) given: Option<HashSet<String>>,
}

fn parse_crease_angle(s: &str) -> Result<f32, String> {
    let v = parse_finite(s)?;
    knobs::CREASE_ANGLE_DEGREES.check(v as f64, s).map(|()| v)
}

fn parse_vec3(s: &str) -> Result<glam::Vec3, String> {
    crate::scene::camera::parse_point(s)
}

fn parse_fov(s: &str) -> Result<f32, String> {
    let v = parse_finite(s)?;
    knobs::FOV_DEGREES.check(v as f64, s).map(|()| v)
}

impl SceneArgs {
    /// The scene spec these flags describe, writing `aov`.
    pub(crate) fn spec(&self, aov: Aov) -> SceneSpec {
        let mut spec = SceneSpec::default();
        self.apply_to(&mut spec, |_| true);
        spec.settings.aov = aov;
        spec
    }

    /// Whether flag `id` (clap's id: the field name) was given on the command line.
    pub(crate) fn given(&self, id: &str) -> bool {
        self.given.as_ref().is_none_or(|g| g.contains(id))
    }

    /// The scene spec to use: the `--preset` (if any) with the flags given beside it over
    /// it, writing `aov` (over a preset only if `aov_given`); and the preset's warnings.
    pub(crate) fn resolve(
        &self,
        aov: Aov,
        aov_given: bool,
    ) -> anyhow::Result<(SceneSpec, Vec<String>)> {
        let Some(path) = &self.preset else {
            return Ok((self.spec(aov), Vec::new()));
        };
        let Loaded { mut spec, warnings } = preset::read(path).map_err(anyhow::Error::msg)?;
        self.apply_to(&mut spec, |id| self.given(id));
        if aov_given {
            spec.settings.aov = aov;
        }
        Ok((spec, warnings))
    }

    /// Set the parts of `spec` whose flags `given` names (by field name, as clap's ids),
    /// leaving the rest: flags over a `--preset`.
    pub(crate) fn apply_to(&self, spec: &mut SceneSpec, given: impl Fn(&str) -> bool) {
        let s = &mut spec.settings;
        if given("model") {
            spec.model = ModelSource::parse(&self.model);
        }
        if given("crease_angle") {
            spec.load_options = LoadOptions { crease_angle: self.crease_angle };
        }
        if given("models") {
            spec.models = self.models;
        }
        if given("scatter") {
            spec.scatter = self.scatter;
        }
        if given("width") {
            s.width = self.width;
        }
        if given("height") {
            s.height = self.height;
        }
        if given("bounces") {
            s.bounces = self.bounces;
        }
        if given("blend") {
            s.blend = self.blend;
        }
        if given("light_angle") {
            spec.light.angle_deg = self.light_angle;
        }
        if given("accel") {
            s.accel = self.accel;
        }
        if let (true, BvhChoice::Layout(layout)) = (given("bvh"), self.bvh) {
            s.bvh = layout;
        }
        if given("smooth") {
            s.smooth = self.smooth;
        }
        if given("no_textures") {
            s.textures = !self.no_textures;
        }
        if given("env") {
            spec.environment = EnvironmentSource::parse(&self.env);
        }
        if given("spp") {
            s.spp = self.spp;
        }
        if given("adaptive") {
            s.adaptive = self.adaptive;
        }
        if given("ao_samples") {
            s.ao_samples = self.ao_samples;
        }
        if given("ao_radius") {
            s.ao_radius = self.ao_radius;
        }
        if given("no_box") {
            spec.mirror_box = !self.no_box;
        }
        if given("eye") {
            spec.camera.eye = self.eye;
        }
        if given("target") {
            spec.camera.target = self.target;
        }
        if given("fov") {
            spec.camera.fov = self.fov;
        }
    }
}

/// `--bvh`: a BVH layout, or `auto`: the window times each and keeps the fastest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BvhChoice {
    /// Picked by timing each (`view` only).
    Auto,
    /// This layout.
    Layout(BvhLayout),
}

impl std::fmt::Display for BvhChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Auto => f.pad("auto"),
            Self::Layout(layout) => layout.fmt(f),
        }
    }
}

impl std::str::FromStr for BvhChoice {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(Self::Auto),
            _ => s.parse().map(Self::Layout).map_err(|_| {
                let names: Vec<String> = BvhLayout::ALL.iter().map(|l| l.to_string()).collect();
                format!("unknown BVH layout '{s}' (expected one of: {}, auto)", names.join(", "))
            }),
        }
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
    /// What to write: color (PNG, JPEG or EXR), ao (ambient occlusion, grey: PNG, JPEG or
    /// EXR), or depth, normal, prim-id, cost, samples (32-bit float OpenEXR; cost and
    /// samples also as a heat-map PNG or JPEG).
    #[arg(long, default_value = "color")]
    pub(crate) aov: Aov,
    /// Output file: .png (carrying its preset in a text chunk), .jpg/.jpeg, or .exr (32-bit
    /// float; the AOVs; depth as a single channel Z).
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    /// Turn on the Vulkan validation layer (also MESHTRACER_VALIDATION=1).
    #[arg(long)]
    pub(crate) validation: bool,
    /// With --accel vendor: trace the driver's structures with ray queries from the compute
    /// shader (query) or a ray tracing pipeline (pipeline). Default: the device's preferred.
    #[arg(long)]
    pub(crate) vendor_kernel: Option<crate::gpu::khr_rt::VendorKernel>,
    /// Average N frames, each with its own camera jitter, as the window's accumulation
    /// does (a screenshot taken after accumulating carries its N) [default: 1, or the preset's].
    #[arg(long, value_name = "N", value_parser = ranged(knobs::ACCUMULATE), allow_negative_numbers = true)]
    pub(crate) accumulate: Option<u32>,
    /// Look through the model file's camera N (1: the first of a glTF file's perspective
    /// cameras), fitted with the model; --eye, --target and --fov still apply over it.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) file_camera: Option<u32>,
}

impl RenderArgs {
    /// The scene spec to render: the `--preset` (if any) with the flags given beside it,
    /// and the preset's warnings.
    pub fn spec(&self) -> anyhow::Result<(SceneSpec, Vec<String>)> {
        if self.scene.bvh == BvhChoice::Auto {
            anyhow::bail!("--bvh auto times each layout over many frames, which only the window (view) does; render takes binary, wide or wide-runs");
        }
        let (mut spec, warnings) = self.scene.resolve(self.aov, self.scene.given("aov"))?;
        if let Some(n) = self.accumulate {
            spec.accumulate = n;
        }
        if let Some(n) = self.file_camera {
            // Over a preset, the file's camera replaces the preset's view.
            let s = &self.scene;
            spec.file_camera = Some(n);
            spec.camera.eye = s.eye.filter(|_| s.given("eye"));
            spec.camera.target = s.target.filter(|_| s.given("target"));
            spec.camera.fov = s.fov.filter(|_| s.given("fov"));
        }
        Ok((spec, warnings))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::view::ViewArgs;
    use crate::cli::{Cli, Command};
    use crate::render_settings::RenderSettings;
    use clap::Parser;

    fn render_args(extra: &[&str]) -> Result<RenderArgs, clap::Error> {
        let cli =
            Cli::try_parse_from(["meshtracer", "render", "-o", "out.png"].iter().chain(extra))?;
        match cli.command {
            Some(Command::Render(args)) => Ok(args),
            other => panic!("not a render command: {other:?}"),
        }
    }

    fn view_args(extra: &[&str]) -> Result<ViewArgs, clap::Error> {
        let cli = Cli::try_parse_from(["meshtracer", "view"].iter().chain(extra))?;
        match cli.command {
            Some(Command::View(args)) => Ok(args),
            other => panic!("not a view command: {other:?}"),
        }
    }

    #[test]
    fn no_flags_give_the_default_scene_spec() {
        // Noted as main parses (no flag given) and as a plain parse (every default given).
        let noted = |args: &[&str]| Cli::try_parse_from_noting_flags(args).unwrap().command;
        for command in [
            noted(&["meshtracer", "render", "-o", "out.png"]),
            Some(Command::Render(render_args(&[]).unwrap())),
        ] {
            let Some(Command::Render(args)) = command else { panic!("not a render command") };
            assert_eq!(args.spec().unwrap(), (SceneSpec::default(), Vec::new()));
        }
        let bare =
            Cli::try_parse_from_noting_flags(["meshtracer"]).unwrap().view.options().unwrap();
        assert_eq!(bare.spec, SceneSpec::default());
        assert_eq!(view_args(&[]).unwrap().options().unwrap().spec, SceneSpec::default());
        let Some(Command::Bench(bench)) = noted(&["meshtracer", "bench"]) else { panic!() };
        let s = RenderSettings::default();
        assert_eq!(
            (bench.bounces, bench.ao_samples, bench.ao_radius),
            (s.bounces, s.ao_samples, s.ao_radius)
        );
    }

    #[test]
    fn benchmark_flag_takes_an_optional_frame_count() {
        assert_eq!(view_args(&[]).unwrap().options().unwrap().benchmark, None);
        assert_eq!(
            view_args(&["--benchmark"]).unwrap().options().unwrap().benchmark,
            Some(crate::app::benchmark::DEFAULT_FRAMES)
        );
        let args = view_args(&["--benchmark", "7", "--benchmark-json", "b.jsonl"]).unwrap();
        let options = args.options().unwrap();
        assert_eq!(options.benchmark, Some(7));
        assert!(options.scripted(), "a benchmark starts with the light still");
        assert_eq!(options.benchmark_json.as_deref(), Some(std::path::Path::new("b.jsonl")));
        assert!(view_args(&["--benchmark", "0"]).is_err());
        assert!(view_args(&["--benchmark", "5", "--frames", "5"])
            .unwrap_err()
            .to_string()
            .contains("cannot be used with"));
    }

    #[test]
    fn the_window_picks_the_layout_unless_told_or_scripted() {
        // As main parses: the flags given are noted (an unnoted parse counts every flag as given).
        let parse = |extra: &[&str]| match Cli::try_parse_from_noting_flags(
            ["meshtracer", "view"].iter().chain(extra),
        )
        .unwrap()
        .command
        {
            Some(Command::View(args)) => args.options().unwrap(),
            other => panic!("not a view command: {other:?}"),
        };
        let auto = |extra: &[&str]| parse(extra).auto_layout;
        let bare =
            Cli::try_parse_from_noting_flags(["meshtracer"]).unwrap().view.options().unwrap();
        assert!(bare.auto_layout, "`meshtracer` alone (cargo run) opens with the measured choice");
        assert!(auto(&[]), "no --bvh: the window times each layout");
        assert!(!auto(&["--frames", "3"]), "a script traces what it asks for");
        assert!(auto(&["--bvh", "auto", "--frames", "3"]), "unless it asks for auto");
        assert!(!auto(&["--bvh", "wide-runs"]));
        assert_eq!(parse(&["--bvh", "wide"]).spec.settings.bvh, BvhLayout::Wide);
        let e = render_args(&["--bvh", "auto"]).unwrap().spec().unwrap_err().to_string();
        assert!(e.contains("--bvh auto") && e.contains("only the window"), "{e}");
        let e = view_args(&["--bvh", "eight"]).unwrap_err().to_string();
        assert!(e.contains("eight") && e.contains("wide-runs, auto"), "{e}");
    }

    #[test]
    fn split_flags_turn_the_split_on() {
        let off = view_args(&[]).unwrap().options().unwrap().split;
        assert!(!off.enabled);
        let on = view_args(&["--split", "0.25", "--split-b", "bounces=0,smooth=off"])
            .unwrap()
            .options()
            .unwrap()
            .split;
        assert!(
            on.enabled
                && on.position == 0.25
                && on.b.bounces == Some(0)
                && on.b.smooth == Some(false)
        );
        let alone = view_args(&["--split-b", "accel=brute"]).unwrap().options().unwrap().split;
        assert!(alone.enabled && alone.position == 0.5);
        assert!(view_args(&["--split"]).unwrap().options().unwrap().split.enabled);
        let e = view_args(&["--split", "2"]).unwrap().options().unwrap_err().to_string();
        assert!(e.contains("out of range"), "{e}");
        let e = view_args(&["--split-b", "bounces=x"]).unwrap().options().unwrap_err().to_string();
        assert!(e.contains("bounces=x") && !e.contains('\n'), "{e}");
    }

    #[test]
    fn crease_angle_reaches_the_spec_and_is_checked() {
        assert_eq!(
            render_args(&[]).unwrap().scene.spec(Aov::Color).load_options.crease_angle,
            None
        );
        let args = render_args(&["--crease-angle", "30"]).unwrap();
        assert_eq!(
            args.scene.spec(Aov::Color).load_options,
            LoadOptions { crease_angle: Some(30.0) }
        );
        for bad in ["-1", "180.5", "nan", "sharp"] {
            let e = render_args(&["--crease-angle", bad]).unwrap_err().to_string();
            assert!(e.contains("--crease-angle") && e.contains(bad), "{bad}: {e}");
        }
    }

    #[test]
    fn a_negative_number_is_out_of_range_not_an_unknown_flag() {
        for (flag, range) in [
            ("--bounces", "0..=8"),
            ("--width", "1..=8192"),
            ("--spp", "1..=64"),
            ("--models", "1..="),
            ("--ao-samples", "1..=256"),
            ("--ao-radius", "0..1000"),
        ] {
            let e = render_args(&[flag, "-1"]).unwrap_err().to_string();
            assert!(
                e.contains(flag) && e.contains(range) && !e.contains("unexpected argument"),
                "{flag}: {e}"
            );
        }
        let e = render_args(&["--blend", "-0.5"]).unwrap_err().to_string();
        assert!(e.contains("out of range (0..=1)"), "{e}");
    }

    #[test]
    fn a_screenshot_path_must_be_a_png() {
        for flag in ["--screenshot", "--screenshot-ui"] {
            let e = view_args(&[flag, "shot.bmp"]).unwrap().options().unwrap_err().to_string();
            assert!(
                e.starts_with(&format!("{flag} shot.bmp: screenshots are written as PNG")),
                "{e}"
            );
            let e = view_args(&[flag, "/no/such/folder/x.png"])
                .unwrap()
                .options()
                .unwrap_err()
                .to_string();
            assert!(e.contains("cannot write /no/such/folder/x.png"), "{e}");
        }
    }
}

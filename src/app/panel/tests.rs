//! The panel driven through egui's own test harness (egui_kittest): widgets found by their
//! label through AccessKit, clicked as a user would, no window or X server. The Xvfb tests
//! in `tests/app_*.rs` keep the real input end to end.

use egui::Vec2;
use egui_kittest::kittest::{NodeT, Queryable};
use egui_kittest::Harness;

use super::{show, PanelAction, PanelInfo, PanelState, VendorInfo, PANEL_WIDTH};
use crate::app::measure::frame_stats::FrameStats;
use crate::app::state::{CostMetric, Params, ViewMode};
use crate::app::user_files::model_loader::LoadStatus;
use crate::gpu::khr_rt::{AccelStats, VendorKernel};
use crate::progress::{Phase, PhaseTime, Snapshot};
use crate::render_settings::Accel;
use crate::scene::paper::ModelSource;
use crate::scene::spec::SceneSpec;
use crate::tracer::packed::SceneHolds;

/// What one harness owns: the parameters and panel state the panel edits, the facts it shows.
struct Fixture {
    params: Params,
    panel: PanelState,
    vendor: VendorInfo,
    stats: FrameStats,
    /// The side panel's width as drawn in the last frame, points.
    panel_width: f32,
    /// A load in progress, as the loader reports it.
    loading: Option<(String, Snapshot)>,
    /// Every action the panel asked for, in order.
    actions: Vec<PanelAction>,
    /// What the scene holds (None: as before the first load).
    holds: Option<SceneHolds>,
}

impl Fixture {
    fn new(vendor: VendorInfo) -> Self {
        Self {
            params: Params::new(&SceneSpec::default(), false),
            panel: PanelState::default(),
            vendor,
            stats: FrameStats::default(),
            panel_width: 0.0,
            loading: None,
            actions: Vec::new(),
            holds: None,
        }
    }
}

/// The facts a panel shows, with nothing loaded or measured.
fn info<'a>(f: &'a Fixture) -> PanelInfo<'a> {
    PanelInfo {
        auto_layout: None,
        device: "test device",
        clock_mhz: None,
        model: None,
        triangles: 1000,
        vertices: 500,
        holds: f.holds,
        settings: f.params.settings_for([256, 256]),
        loading: f
            .loading
            .as_ref()
            .map(|(label, snapshot)| LoadStatus { label, snapshot: snapshot.clone() }),
        present_mode: "FIFO".into(),
        vsync_off_available: false,
        heat: Some((100.0, 120.0, 30.0)),
        view_note: None,
        accumulated_frames: 0,
        progress: None,
        brute_tests: 0.0,
        submission_tests: 1e9,
        screenshot_dir: "/tmp".into(),
        stats: &f.stats,
        benchmark: None,
        recording: None,
        settings_file: None,
        vendor: &f.vendor,
        split_ms: [None, None],
    }
}

/// The panel as the tool lays it out: a resizable left panel of the default width, at most
/// two fifths of the window.
fn harness(size: Vec2, fixture: Fixture) -> Harness<'static, Fixture> {
    Harness::builder().with_size(size).build_ui_state(
        |ui, f: &mut Fixture| {
            let (width, range) = super::panel_widths(ui.available_width());
            let response =
                egui::Panel::left("panel").default_size(width).size_range(range).show(ui, |ui| {
                    // The panel edits a copy of what the facts borrow, as the tool's frame does.
                    let mut params = f.params.clone();
                    let mut panel = std::mem::take(&mut f.panel);
                    let actions = show(ui, &mut params, &mut panel, &info(f));
                    f.actions.extend(actions);
                    f.panel = panel;
                    f.params = params;
                });
            f.panel_width = response.response.rect.width();
        },
        fixture,
    )
}

fn no_vendor() -> VendorInfo {
    VendorInfo {
        unavailable: Some("this device has no VK_KHR_ray_query".into()),
        ..Default::default()
    }
}

#[test]
fn the_split_views_b_side_offers_no_vendor_the_device_lacks() {
    // #30: A greyed the vendor out, B offered it, and picking it printed the error inside
    // the Render section.
    let mut fixture = Fixture::new(no_vendor());
    fixture.params.split.enabled = true;
    fixture.params.split.b.accel = Some(Accel::Bvh);
    let mut h = harness(Vec2::new(1280.0, 2400.0), fixture);
    h.get_by_label("A/B split").click();
    h.run();
    let vendors: Vec<_> = h.query_all_by_label("vendor").collect();
    assert_eq!(vendors.len(), 2, "A's choice and B's");
    assert!(
        vendors.iter().all(|v| v.accesskit_node().is_disabled()),
        "every vendor choice greyed out"
    );
    let b_vendor = vendors
        .iter()
        .max_by(|a, b| a.rect().top().total_cmp(&b.rect().top()))
        .unwrap()
        .rect()
        .center();
    h.hover_at(b_vendor);
    h.event(egui::Event::PointerButton {
        pos: b_vendor,
        button: egui::PointerButton::Primary,
        pressed: true,
        modifiers: Default::default(),
    });
    h.event(egui::Event::PointerButton {
        pos: b_vendor,
        button: egui::PointerButton::Primary,
        pressed: false,
        modifiers: Default::default(),
    });
    h.run();
    assert_eq!(
        h.state().params.split.b.accel,
        Some(Accel::Bvh),
        "a greyed-out choice cannot be picked"
    );
}

#[test]
fn long_lines_wrap_inside_the_panel_instead_of_widening_it() {
    // #30: the vendor's "Structures" line widened the panel from ~320 to ~490 px at
    // 1280x800 (the image shrank) and was cut off at 900x600; the cost legend too.
    for size in [Vec2::new(1280.0, 800.0), Vec2::new(900.0, 600.0)] {
        let mut plain = harness(size, Fixture::new(VendorInfo::default()));
        plain.run();
        let usual = plain.state().panel_width;
        assert!(usual <= PANEL_WIDTH + 20.0, "{size:?}: the panel starts {usual} points wide");

        let vendor = VendorInfo {
            kernel: Some(VendorKernel::Query),
            kernels: vec![VendorKernel::Query, VendorKernel::Pipeline],
            stats: Some(AccelStats {
                bottom_count: 27,
                bottom_ms: 1234.5,
                top_ms: 67.8,
                bytes: 799_000_000,
                primitives: 10_000_000,
                rebuilt: "bottom and top levels",
            }),
            ..Default::default()
        };
        let mut fixture = Fixture::new(vendor);
        fixture.params.scene.settings.accel = Accel::Vendor;
        fixture.params.view = ViewMode::Cost(CostMetric::Nodes);
        let mut h = harness(size, fixture);
        h.run();
        let width = h.state().panel_width;
        assert!(
            width <= usual + 0.5,
            "{size:?}: the long lines widened the panel from {usual} to {width} points"
        );
        let structures = h.get_by_label_contains("bottom levels");
        assert!(
            structures.rect().right() <= width + 0.5,
            "{size:?}: the line runs past the panel ({} > {width})",
            structures.rect().right()
        );
    }
}

#[test]
fn a_load_shows_its_phases_and_cancels_from_the_panel() {
    let mut fixture = Fixture::new(VendorInfo::default());
    let phases = vec![
        PhaseTime { phase: Phase::Read, seconds: 0.25, done: true, peak_rss_bytes: None },
        PhaseTime { phase: Phase::Parse, seconds: 1.5, done: false, peak_rss_bytes: None },
    ];
    fixture.loading = Some(("dragon".into(), Snapshot { phases, fraction: 0.5 }));
    let mut h = harness(Vec2::new(1280.0, 2400.0), fixture);
    h.run_steps(2); // the bar animates: it never settles
                    // The running phase on the bar, the finished ones with their times.
    h.get_by_label_contains("dragon: parse 1.5 s");
    h.get_by_label_contains("read 0.25 s");
    h.get_by_label("Cancel").click();
    h.run_steps(2); // the bar animates: it never settles
    assert!(h.state().actions.contains(&PanelAction::CancelLoad), "{:?}", h.state().actions);
}

// ---- #43 points 3, 9, 10: the graph's zoom, the panel's width, the numbers ----

/// A fixture whose graph has 60 s of 200-800 ms frames.
fn with_slow_frames() -> Fixture {
    let mut fixture = Fixture::new(VendorInfo::default());
    for i in 0..120 {
        let t = i as f64 * 0.5;
        fixture.stats.push_frame(t, 200.0 + (i % 7) as f64 * 100.0);
    }
    fixture
}

/// The x range the graph shows now.
fn graph_x(h: &Harness<'_, Fixture>) -> [f64; 2] {
    let memory = egui_plot::PlotMemory::load(&h.ctx, super::performance::graph_id())
        .expect("the graph was drawn");
    [memory.bounds().min()[0], memory.bounds().max()[0]]
}

/// Zoom the graph into 2-1 s ago, as a drag across it leaves it.
fn zoom_graph(h: &mut Harness<'_, Fixture>) {
    let id = super::performance::graph_id();
    let mut memory = egui_plot::PlotMemory::load(&h.ctx, id).expect("the graph was drawn");
    memory.auto_bounds = false.into();
    memory.set_bounds(egui_plot::PlotBounds::from_min_max([-2.0, 0.0], [-1.0, 900.0]));
    memory.store(&h.ctx, id);
    h.run();
    let [min, max] = graph_x(h);
    assert!(min >= -2.01 && max <= -0.99, "the zoom holds: {min}..{max}");
}

#[test]
fn choosing_a_window_after_a_zoom_shows_that_whole_window() {
    // #43: after "10 s" the graph kept the zoomed range and was empty.
    let mut h = harness(Vec2::new(1280.0, 2400.0), with_slow_frames());
    h.run();
    for (button, seconds) in [("10 s", 10.0), ("30 s", 30.0), ("10 s", 10.0)] {
        zoom_graph(&mut h);
        h.get_by_label(button).click();
        h.run();
        let [min, max] = graph_x(&h);
        assert!(min <= -seconds && max >= 0.0, "{button}: the graph shows {min}..{max}");
        assert!(min >= -seconds * 1.2, "{button}: the graph shows {min}..{max}");
    }
}

#[test]
fn a_double_click_and_reset_settings_leave_the_zoom() {
    // #43: neither a double click nor "Reset settings" brought the graph back.
    let mut h = harness(Vec2::new(1280.0, 2400.0), with_slow_frames());
    h.run();
    zoom_graph(&mut h);
    // The middle of the graph, which sits above its window buttons.
    let below = h.get_by_label("10 s").rect();
    let graph = egui::pos2(below.center().x, below.top() - 50.0);
    h.hover_at(graph);
    // The harness's passes are 0.25 s apart: two clicks one pass apart each are a double
    // click once the delay allows a second.
    h.ctx.options_mut(|o| o.input_options.max_double_click_delay = 1.0);
    for pressed in [true, false, true, false] {
        h.event(egui::Event::PointerButton {
            pos: graph,
            button: egui::PointerButton::Primary,
            pressed,
            modifiers: Default::default(),
        });
        h.step();
    }
    h.run();
    let [min, max] = graph_x(&h);
    assert!(min <= -10.0 && max >= 0.0, "double click: the graph shows {min}..{max}");

    zoom_graph(&mut h);
    let ctx = h.ctx.clone();
    super::remembered::reset(&mut h.state_mut().panel, &ctx);
    h.run();
    let [min, max] = graph_x(&h);
    assert!(min <= -10.0 && max >= 0.0, "Reset settings: the graph shows {min}..{max}");
}

#[test]
fn opening_keys_leaves_the_panel_as_wide_as_it_was() {
    // #43: opening Keys widened the panel from about 300 to 570 points for the rest of the run.
    for size in [Vec2::new(1280.0, 2400.0), Vec2::new(640.0, 2400.0)] {
        let mut h = harness(size, Fixture::new(VendorInfo::default()));
        h.run();
        let before = h.state().panel_width;
        h.get_by_label("Keys").click();
        h.run();
        let after = h.state().panel_width;
        assert!(after <= before + 2.0, "{size:?}: Keys widened the panel from {before} to {after}");
        let line = h.get_by_label_contains("orbit / zoom the camera");
        assert!(line.rect().right() <= after + 0.5, "{size:?}: a key's line runs past the panel");
    }
}

// ---- #44: what the scene holds, and scattered copies ----

/// A fixture whose scene holds 10,000 copies of the geosphere and the mirror box.
fn holding_ten_thousand_copies() -> Fixture {
    let mut fixture = Fixture::new(VendorInfo::default());
    fixture.holds = Some(SceneHolds {
        meshes: 2,
        instances: 10_001,
        unique_triangles: 92,
        instanced_triangles: 800_012,
        top_bytes: 1_440_144,
        bottom_bytes: 7_520,
    });
    fixture
}

#[test]
fn the_model_section_says_what_the_scene_holds_and_scatters_copies() {
    let fixture = holding_ten_thousand_copies();
    let mut h = harness(Vec2::new(1280.0, 2400.0), fixture);
    h.run();
    h.get_by_label_contains("2 meshes, 10 001 instances: 92 triangles stored, 800 012 placed");
    h.get_by_label_contains("top level 1.37 MiB, bottom levels 7.34 KiB");
    assert_eq!(h.state().params.scene.scatter, 0, "the paper's identical copies");
    h.get_by_label("turn and scale copies at random").click();
    h.run();
    assert_eq!(h.state().params.scene.scatter, 1);
    h.get_by_label("turn and scale copies at random").click();
    h.run();
    assert_eq!(h.state().params.scene.scatter, 0);
}

// ---- #43 points 9 and 12: the layout, the load bar, recent models, the environment ----

#[test]
fn at_640_by_480_the_panel_leaves_the_image_most_of_the_window() {
    // #43: at 640x480 the panel's rows pushed it to half the window (320 points).
    let mut h = harness(Vec2::new(640.0, 480.0), Fixture::new(VendorInfo::default()));
    h.run();
    let width = h.state().panel_width;
    assert!(width <= PANEL_WIDTH + 0.5, "the panel is {width} of 640 points wide");
    let mut wide = harness(Vec2::new(1280.0, 800.0), Fixture::new(VendorInfo::default()));
    wide.run();
    assert!((wide.state().panel_width - PANEL_WIDTH).abs() < 20.0, "a big window keeps 300");
}

#[test]
fn the_scroll_bar_has_a_column_of_its_own() {
    // #43: a label ran under the panel's (floating) scroll bar.
    let fixture = holding_ten_thousand_copies();
    // Short: the sections scroll.
    let mut h = harness(Vec2::new(1280.0, 500.0), fixture);
    h.run();
    let bar = egui::style::ScrollStyle::solid().bar_width;
    let right = h.get_by_label("hide (H)").rect().right();
    let line = h.get_by_label_contains("instances: 92 triangles stored").rect();
    assert!(line.right() <= right - bar, "the line ends at {} under the bar", line.right());
}

#[test]
fn the_load_bar_moves_while_the_build_reports_nothing() {
    // #43: the bar stood still through the BVH build.
    let bar = |seconds, fraction| {
        let phases = vec![
            PhaseTime { phase: Phase::Parse, seconds: 2.0, done: true, peak_rss_bytes: None },
            PhaseTime { phase: Phase::Build, seconds, done: false, peak_rss_bytes: None },
        ];
        super::model::bar_fraction(&Snapshot { phases, fraction })
    };
    let (start, later, much_later) = (bar(0.0, 0.0), bar(2.0, 0.0), bar(60.0, 0.0));
    assert!(start < later && later < much_later, "{start} {later} {much_later}");
    assert!(much_later < 2.0 / Phase::ALL.len() as f32, "never past the build's share");
    assert_eq!(bar(2.0, 0.5), 1.5 / Phase::ALL.len() as f32, "a reported fraction is kept");
}

#[test]
fn a_recent_model_loads_again_with_a_click() {
    let mut fixture = Fixture::new(VendorInfo::default());
    let (bunny, dragon) =
        (std::path::PathBuf::from("/m/bunny.obj"), std::path::PathBuf::from("/m/dragon.ply"));
    fixture.panel.model.loaded(&bunny);
    fixture.panel.model.loaded(&dragon);
    fixture.panel.model.loaded(&bunny);
    assert_eq!(fixture.panel.model.recent, [bunny.clone(), dragon.clone()], "latest first, once");
    let mut h = harness(Vec2::new(1280.0, 2400.0), fixture);
    h.run();
    h.get_by_label("dragon.ply").click();
    h.run();
    assert_eq!(h.state().actions, [PanelAction::LoadFile(dragon)]);
    // Remembered between runs, and forgotten on Reset settings.
    let ctx = h.ctx.clone();
    let kept = super::remembered::snapshot(None, &h.state().panel, &ctx);
    assert_eq!(kept.recent_models.len(), 2);
    let mut next = PanelState::default();
    super::remembered::restore(&kept, &mut next, &ctx);
    assert_eq!(next.model.recent, kept.recent_models);
    super::remembered::reset(&mut next, &ctx);
    assert!(next.model.recent.is_empty());
}

#[test]
fn the_environment_map_is_chosen_in_the_panel() {
    // #43: the environment file could only be given with --env.
    let mut h = harness(Vec2::new(1280.0, 2400.0), Fixture::new(VendorInfo::default()));
    h.run();
    h.get_by_label("file…").click();
    h.run();
    use crate::app::user_files::open_dialog::Purpose;
    assert_eq!(h.state().actions, [PanelAction::Open(Purpose::Environment)]);
    // The dialog's pick: traced now and offered in the list from then on.
    let mut params = Params::new(&SceneSpec::default(), false);
    params.use_environment_file("/maps/studio.hdr".into());
    let file = crate::scene::EnvironmentSource::File("/maps/studio.hdr".into());
    assert_eq!(params.scene.environment, Some(file.clone()));
    assert_eq!(params.environment_file, Some(file));
}

#[test]
fn a_name_typed_and_load_clicked_in_one_frame_loads_it() {
    let mut h = harness(Vec2::new(1280.0, 2400.0), Fixture::new(VendorInfo::default()));
    h.run();
    // The model section's Load (the presets' comes after it). With nothing typed it says
    // what is missing, and loads nothing.
    let load = |h: &Harness<'_, Fixture>| h.get_all_by_label("Load").next().unwrap().click();
    load(&h);
    h.run();
    assert!(h.state().actions.is_empty(), "{:?}", h.state().actions);
    let status = h.state().panel.model.status.as_ref().map(|s| s.text.clone());
    assert!(status.as_ref().is_some_and(|s| s.contains("type a model")), "{status:?}");
    // On a slow machine the name and the click arrive in one frame, after a frame whose
    // field was empty.
    h.state_mut().panel.model.path = "torusknot:300k".into();
    load(&h);
    h.run();
    let knot = PanelAction::LoadModel(ModelSource::parse("torusknot:300k"));
    assert_eq!(h.state().actions, [knot]);
}

//! Tests of the preset format: round trips, where errors point, unknown keys, saving.

use super::*;
use crate::scene::paper::ModelSource;

fn rich_spec() -> SceneSpec {
    SceneSpec {
        model: ModelSource::File("models/my \"bunny\".obj".into()),
        load_options: crate::scene::obj::LoadOptions { crease_angle: Some(30.0) },
        models: 700,
        scatter: 42,
        objects: vec![
            ObjectSpec {
                model: ModelSource::File("models/dragon.ply".into()),
                placement: Placement {
                    translate: Vec3::new(2.5, -0.5, 1.0),
                    rotate: Vec3::new(0.0, 45.0, -10.0),
                    scale: Vec3::new(0.5, 0.75, -0.5),
                },
            },
            ObjectSpec {
                model: ModelSource::Generated(20_000),
                placement: Placement { translate: Vec3::new(-2.0, 0.0, 0.0), ..Default::default() },
            },
        ],
        mirror_box: false,
        light: LightOrbit { radius: 3.25, height: -1.5, angle_deg: 123.456 },
        camera: CameraSpec {
            eye: Some(Vec3::new(0.1, -2.0, 3.3)),
            target: Some(Vec3::new(0.0, 0.25, 0.0)),
            fov: Some(37.5),
            framed: false,
        },
        file_camera: None,
        environment: Some(EnvironmentSource::File("skies/noon.hdr".into())),
        settings: RenderSettings {
            width: 640,
            height: 360,
            bounces: 5,
            blend: 0.3,
            accel: Accel::Brute,
            bvh: crate::render_settings::BvhLayout::Wide,
            aov: Aov::PrimId,
            smooth: true,
            textures: false,
            spp: 16,
            adaptive: true,
            ao_samples: 32,
            ao_radius: 0.125,
        },
        accumulate: 40,
    }
}

#[test]
fn presets_round_trip() {
    let spec = rich_spec();
    let text = to_text(&spec);
    assert!(text.starts_with("# meshtracer preset"), "{text}");
    assert!(
        !to_text(&SceneSpec::default()).contains("crease_angle"),
        "an unset crease angle is left out"
    );
    for needle in [
        "version = 1\n",
        "[model]\n",
        "crease_angle = 30.0\n",
        "source = 'models/my \"bunny\".obj'",
        "copies = 700\n",
        "scatter = 42\n",
        "[camera]\n",
        "accel = \"brute\"\n",
        "aov = \"prim-id\"\n",
        "environment = \"skies/noon.hdr\"\n",
        "angle = 123.456\n",
        "ao_samples = 32\n",
        "ao_radius = 0.125\n",
    ] {
        assert!(text.contains(needle), "no {needle:?} in:\n{text}");
    }
    let (back, unknown) = from_text(&text).unwrap();
    assert!(unknown.is_empty());
    assert_eq!(back, spec);
    assert_eq!(to_text(&back), text);
    // Generated models, the sky and the defaults too; an unset or framed camera is written
    // resolved, so it reads back as the same camera spelled out.
    for spec in [
        SceneSpec {
            model: ModelSource::Generated(250_000),
            environment: Some(EnvironmentSource::Sky),
            ..SceneSpec::default()
        },
        SceneSpec {
            camera: CameraSpec { framed: true, ..CameraSpec::default() },
            ..SceneSpec::default()
        },
        SceneSpec::default(),
    ] {
        let (back, _) = from_text(&to_text(&spec)).unwrap();
        assert_eq!(back, SceneSpec { camera: spec.camera.resolved(), ..spec.clone() });
        assert_eq!(back.camera.camera(), spec.camera.camera());
        assert_eq!(to_text(&back), to_text(&spec));
    }
}

#[test]
fn keys_left_out_keep_their_defaults() {
    let (spec, unknown) =
        from_text("version = 1\n[tracing]\nbounces = 4\n[light]\nangle = 10\n").unwrap();
    assert!(unknown.is_empty());
    assert_eq!(spec.settings.bounces, 4);
    assert_eq!(spec.light.angle_deg, 10.0);
    let default = SceneSpec::default();
    assert_eq!(spec.settings.width, default.settings.width);
    assert_eq!(spec.camera.camera(), default.camera.camera());
    // No version at all reads as this version; an empty file is the default scene.
    assert_eq!(
        from_text("").unwrap().0,
        SceneSpec { camera: default.camera.resolved(), ..default }
    );
}

#[test]
fn a_bad_value_names_its_key_and_line() {
    for (text, line, key, says) in [
        (
            "version = 1\n[tracing]\nbounces = 12\n",
            3,
            "tracing.bounces",
            "12 is out of range (0..=8)",
        ),
        ("[image]\nwidth = 64\nheight = 0\n", 3, "image.height", "out of range (1..=8192)"),
        ("[tracing]\naccel = \"fast\"\n", 2, "tracing.accel", "unknown acceleration 'fast'"),
        ("[tracing]\nblend = 2\n", 2, "tracing.blend", "out of range (0..=1)"),
        ("[shading]\nsmooth = \"maybe\"\n", 2, "shading.smooth", "expected a boolean"),
        ("[camera]\neye = [1, 2]\n", 2, "camera.eye", "expected [x, y, z]"),
        ("[camera]\nfov = 500\n", 2, "camera.fov", "out of range"),
        ("[model]\nsource = \"geosphre\"\n", 2, "model.source", "geosphere, torusknot"),
        ("[model]\ncopies = -3\n", 2, "model.copies", "out of range (1..=10000)"),
        (
            "[model]\ncrease_angle = 200\n",
            2,
            "model.crease_angle",
            "out of range (0..=180 degrees)",
        ),
        ("version = 2\n", 1, "version", "format version 2"),
        ("[camera]\neye = [0, 0, 0]\ntarget = [0, 0, 0]\n", 3, "camera.target", "same point"),
        ("[image]\nwidth 64\n", 2, "", "expected"),
        ("[image]\nao_samples = 0\n", 2, "image.ao_samples", "0 is out of range (1..=256)"),
        ("[[object]]\ntranslate = [1, 2, 3]\n", 1, "object", "missing field `model`"),
        (
            "[[object]]\nmodel = \"sphere\"\n[[object]]\nmodel = \"cylinder\"\nscale = [1, 0, 1]\n",
            5,
            "object[2].scale",
            "a finite number other than 0",
        ),
        (
            "[[object]]\nmodel = \"sphere\"\nscale = [1, 2]\n",
            3,
            "object[1].scale",
            "got 2 number(s)",
        ),
        ("[[object]]\nmodel = \"spere\"\n", 2, "object[1].model", "geosphere, torusknot"),
        (
            "[[object]]\nmodel = \"sphere\"\nscale = [1e-30, 1, 1]\n",
            1,
            "object",
            "object 1 (sphere) has a singular",
        ),
        (
            "[image]\nao_radius = -1\n",
            2,
            "image.ao_radius",
            "-1 is out of range (0..1000 scene units)",
        ),
    ] {
        let e = from_text(text).unwrap_err();
        assert_eq!(e.line, Some(line), "{text:?}: {e}");
        if key.is_empty() {
            assert!(e.to_string().starts_with(&format!("line {line}")), "{e}");
        } else {
            assert_eq!(e.key.as_deref(), Some(key), "{text:?}: {e}");
            assert!(e.to_string().starts_with(&format!("line {line}, key '{key}': ")), "{e}");
        }
        assert!(e.to_string().contains(says), "{text:?}: {e}");
        assert!(!e.to_string().contains('\n'), "{e:?}");
    }
}

#[test]
fn objects_read_with_defaults_and_a_uniform_scale() {
    let text = "[[object]]\nmodel = \"sphere\"\nscale = 0.5\ncolour = 1\n\
                [[object]]\nmodel = \"torusknot:2k\"\nrotate = [0, 90, 0]\n";
    let (spec, unknown) = from_text(text).unwrap();
    let found: Vec<(&str, usize)> = unknown.iter().map(|u| (u.key.as_str(), u.line)).collect();
    assert_eq!(found, [("object[1].colour", 4)], "an unknown key in an object is a warning");
    assert_eq!(spec.objects.len(), 2);
    let [a, b] = [&spec.objects[0], &spec.objects[1]];
    assert_eq!(a.model, ModelSource::parse("sphere"));
    assert_eq!(a.placement, Placement { scale: Vec3::splat(0.5), ..Default::default() });
    assert_eq!(b.model, ModelSource::Generated(2000));
    assert_eq!(b.placement.translate, Vec3::ZERO);
    assert_eq!(b.placement.scale, Vec3::ONE);
    // 90 degrees about y takes +x to -z.
    let x = b.placement.transform().transform_vector3(Vec3::X);
    assert!((x - Vec3::NEG_Z).length() < 1e-6, "{x}");
}

#[test]
fn unknown_keys_are_reported_with_their_lines() {
    let text = "version = 1\ncolour = 3\n[image]\nwidth = 64\nhieght = 32\n[extras]\nx = 1\n";
    let (spec, unknown) = from_text(text).unwrap();
    assert_eq!(spec.settings.width, 64);
    let found: Vec<(&str, usize)> = unknown.iter().map(|u| (u.key.as_str(), u.line)).collect();
    assert_eq!(found, [("colour", 2), ("extras", 6), ("image.hieght", 5)]);
}

#[test]
fn saving_renames_into_place_and_asks_before_overwriting() {
    let dir = std::env::temp_dir().join(format!("meshtracer-preset-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("look.toml");
    let spec = rich_spec();
    save(&spec, &path, false).unwrap();
    let loaded = read(&path).unwrap();
    assert_eq!(loaded.spec, spec);
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let other = SceneSpec { models: 3, ..spec.clone() };
    assert_eq!(save(&other, &path, false), Err(SaveError::Exists(path.clone())));
    assert_eq!(read(&path).unwrap().spec, spec, "refused: the file is unchanged");
    save(&other, &path, true).unwrap();
    assert_eq!(read(&path).unwrap().spec.models, 3);
    let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names, ["look.toml"], "no temporary file left behind");
    // Errors name the file: unreadable, unwritable, bad value, a PNG without settings.
    std::fs::write(dir.join("bad.toml"), "[tracing]\nbounces = 99\n").unwrap();
    let e = read(&dir.join("bad.toml")).unwrap_err();
    assert!(
        e.starts_with(&format!(
            "preset {}: line 2, key 'tracing.bounces'",
            dir.join("bad.toml").display()
        )),
        "{e}"
    );
    assert!(read(&dir.join("missing.toml")).unwrap_err().contains("missing.toml"));
    let e = save(&spec, &dir.join("no/such/dir.toml"), false).unwrap_err();
    assert!(
        e.to_string().starts_with("could not write the preset")
            && e.to_string().contains("dir.toml"),
        "{e}"
    );
    image::RgbaImage::new(2, 2).save(dir.join("plain.png")).unwrap();
    assert!(read(&dir.join("plain.png")).unwrap_err().contains("has no meshtracer settings"));
    std::fs::write(dir.join("typo.toml"), "[shading]\nsmoth = true\n").unwrap();
    let warnings = read(&dir.join("typo.toml")).unwrap().warnings;
    assert_eq!(warnings.len(), 1);
    assert!(
        warnings[0].contains("typo.toml")
            && warnings[0].contains("'shading.smoth'")
            && warnings[0].contains("line 2"),
        "{warnings:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn relative_paths_are_read_beside_the_preset_and_saved_absolute() {
    let dir = std::env::temp_dir().join(format!("meshtracer-preset-paths-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("knot.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    std::fs::write(dir.join("look.toml"), "version = 1\n[model]\nsource = \"knot.obj\"\n").unwrap();
    let spec = read(&dir.join("look.toml")).unwrap().spec;
    assert_eq!(spec.model, ModelSource::File(dir.join("knot.obj")), "found beside the preset");
    // A name with no file beside the preset stays as written (the working folder's).
    std::fs::write(dir.join("elsewhere.toml"), "version = 1\n[model]\nsource = \"not-here.obj\"\n")
        .unwrap();
    assert_eq!(
        read(&dir.join("elsewhere.toml")).unwrap().spec.model,
        ModelSource::File("not-here.obj".into())
    );
    // Saving writes the absolute path, so the preset works from any folder.
    let relative =
        SceneSpec { model: ModelSource::File(dir.join("knot.obj")), ..SceneSpec::default() };
    save(&relative, &dir.join("saved.toml"), false).unwrap();
    let text = std::fs::read_to_string(dir.join("saved.toml")).unwrap();
    let absolute = std::fs::canonicalize(dir.join("knot.obj")).unwrap();
    assert!(text.contains(&absolute.display().to_string()), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

//! glTF as it is authored (issue #45): textures the right way up from every place a file
//! keeps them, accessors as the spec reads them, files the Khronos validator accepts read
//! even where the `gltf` crate was stricter, nodes as instances of meshes stored once, and
//! one-line refusals. Every file is written here.

mod common;

use common::gltf::glb;

use std::path::Path;

use common::*;
use glam::{Affine3A, Mat4, Quat, Vec2, Vec3};
use meshtracer::gpu::khr_rt::VendorKernel;
use meshtracer::gpu::ComputeTracer;
use meshtracer::render_settings::{Accel, RenderSettings};
use meshtracer::scene::formats::{load_model, LoadedModel};
use meshtracer::scene::gltf::{load_gltf_from_bytes, LoadedGltf};
use meshtracer::scene::obj::LoadOptions;
use meshtracer::scene::paper::{prepare_model, ModelSource};
use meshtracer::scene::{Camera, Model, PointLight, Scene, TextureSource};
use meshtracer::tracer::{cpu, FrameParams, Image, PackedScene};

// ---------------------------------------------------------------------------------------
// Writing files

fn f32s(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Every byte but the URI's unreserved characters as `%XX`.
fn percent_encoded(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|&b| {
            if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
                (b as char).to_string()
            } else {
                format!("%{b:02X}")
            }
        })
        .collect()
}

/// An 8x8 PNG: red on the top half, blue on the bottom.
fn two_colour_png() -> Vec<u8> {
    let img = image::RgbaImage::from_fn(8, 8, |_, y| {
        image::Rgba(if y < 4 { [255, 0, 0, 255] } else { [0, 0, 255, 255] })
    });
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// The unit quad facing +z: positions, normals, glTF texture coordinates (origin at the
/// image's top-left: the top edge has v = 0), u16 indices. 140 bytes.
fn quad_bin() -> Vec<u8> {
    let mut bin = f32s(&[-1., -1., 0., 1., -1., 0., 1., 1., 0., -1., 1., 0.]);
    bin.extend(f32s(&[0., 0., 1., 0., 0., 1., 0., 0., 1., 0., 0., 1.]));
    bin.extend(f32s(&[0., 1., 1., 1., 1., 0., 0., 0.]));
    bin.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    bin
}

/// The textured quad's document: `buffer` is the buffer's JSON, `image` the image's.
fn quad_json(buffer: &str, image: &str, extra_views: &str) -> String {
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"mesh": 0}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}}, "indices": 3, "material": 0}}]}}],
  "materials": [{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}}, "metallicFactor": 0}}}}],
  "textures": [{{"source": 0, "sampler": 0}}],
  "samplers": [{{"wrapS": 33071, "wrapT": 33071}}],
  "images": [{image}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"}},
    {{"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"}},
    {{"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}}
  ],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 48, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 96, "byteLength": 32}},
    {{"buffer": 0, "byteOffset": 128, "byteLength": 12}}{extra_views}
  ],
  "buffers": [{buffer}]
}}"#
    )
}

/// The OBJ twin of the textured quad: OBJ's texture origin is the bottom-left corner.
const QUAD_OBJ: &str = "mtllib quad.mtl\nusemtl tex\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n\
vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n";
// The same image under a name without a space (.mtl names are not percent-encoded).
const QUAD_MTL: &str = "newmtl tex\nKd 1 1 1\nKs 0 0 0\nmap_Kd -clamp on twocolour.png\n";

// ---------------------------------------------------------------------------------------
// Loading and rendering

fn load(path: &Path) -> LoadedModel {
    load_model(&ModelSource::File(path.to_owned()), &LoadOptions::default(), None)
        .unwrap_or_else(|e| panic!("{e}"))
}

fn parse(json: &str) -> LoadedGltf {
    load_gltf_from_bytes(json.as_bytes(), "test.gltf", None).unwrap_or_else(|e| panic!("{e}"))
}

/// `model` as placed, seen head-on from +z with the light at the camera.
fn scene_of(model: &Model) -> Scene {
    Scene {
        meshes: model.meshes.clone(),
        instances: model.parts.clone(),
        camera: Camera {
            position: Vec3::new(0.0, 0.0, 3.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 60.0,
        },
        light: PointLight { position: Vec3::new(0.0, 0.0, 3.0), color: Vec3::ONE },
        background: Vec3::ZERO,
        ambient: 0.1,
        environment: None,
        assembly: Default::default(),
    }
}

fn cpu_render(scene: &Scene, settings: RenderSettings) -> Image {
    let packed = PackedScene::new(scene);
    assert!(packed.warnings.is_empty(), "{:?}", packed.warnings);
    cpu::render(&packed, &FrameParams::new(scene, settings))
}

/// Matte white under the texture, so the image shows the texture alone: the twins' other
/// material values are read from different things (Ks against metallic).
fn matte(model: &mut Model) {
    for m in model.meshes.iter_mut().flat_map(|m| &mut m.materials) {
        m.diffuse = Vec3::ONE;
        m.specular = Vec3::ZERO;
        m.mirror = 0.0;
    }
}

fn largest_difference(a: &Image, b: &Image) -> f32 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(x, y)| (0..3).map(move |i| (x[i] - y[i]).abs()))
        .fold(0.0, f32::max)
}

// ---------------------------------------------------------------------------------------
// Textures

#[test]
fn a_texture_is_the_right_way_up_from_every_place_a_file_keeps_it() {
    let dir = Scratch::new("texture");
    let png = two_colour_png();
    let bin = quad_bin();
    std::fs::write(dir.join("two colour.png"), &png).unwrap();
    std::fs::write(dir.join("twocolour.png"), &png).unwrap();
    std::fs::write(dir.join("quad.bin"), &bin).unwrap();
    std::fs::write(dir.join("quad.obj"), QUAD_OBJ).unwrap();
    std::fs::write(dir.join("quad.mtl"), QUAD_MTL).unwrap();

    // The image in the GLB's binary chunk, after the quad (140 bytes, a multiple of four).
    let mut glb_bin = bin.clone();
    glb_bin.extend(&png);
    let view = format!(r#", {{"buffer": 0, "byteOffset": 140, "byteLength": {}}}"#, png.len());
    let json = quad_json(
        &format!(r#"{{"byteLength": {}}}"#, glb_bin.len()),
        r#"{"bufferView": 4, "mimeType": "image/png"}"#,
        &view,
    );
    std::fs::write(dir.join("view.glb"), glb(&json, &glb_bin)).unwrap();
    let data_buffer = format!(
        r#"{{"uri": "data:application/octet-stream;base64,{}", "byteLength": 140}}"#,
        base64(&bin)
    );
    let base64_image = format!(r#"{{"uri": "data:image/png;base64,{}"}}"#, base64(&png));
    std::fs::write(dir.join("base64.gltf"), quad_json(&data_buffer, &base64_image, "")).unwrap();
    let percent_image = format!(r#"{{"uri": "data:image/png,{}"}}"#, percent_encoded(&png));
    std::fs::write(dir.join("percent.gltf"), quad_json(&data_buffer, &percent_image, "")).unwrap();
    let file_buffer = r#"{"uri": "quad.bin", "byteLength": 140}"#;
    let file_image = r#"{"uri": "two%20colour.png"}"#;
    std::fs::write(dir.join("file.gltf"), quad_json(file_buffer, file_image, "")).unwrap();

    let settings = RenderSettings { bounces: 0, ..settings(64, 0) };
    let mut obj = load(&dir.join("quad.obj"));
    matte(&mut obj.model);
    let obj_image = cpu_render(&scene_of(&obj.model), settings);
    // The quad spans rows 14 to 50: row 23 is its top quarter, row 41 its bottom quarter.
    let (top, bottom) = (obj_image.get(32, 23), obj_image.get(32, 41));
    assert!(top[0] > 0.5 && top[2] < 0.05, "the OBJ's top is red: {top:?}");
    assert!(bottom[2] > 0.5 && bottom[0] < 0.05, "the OBJ's bottom is blue: {bottom:?}");

    for (file, embedded) in
        [("view.glb", true), ("base64.gltf", true), ("percent.gltf", true), ("file.gltf", false)]
    {
        let mut loaded = load(&dir.join(file));
        assert!(loaded.warnings.is_empty(), "{file}: {:?}", loaded.warnings);
        let material = &loaded.model.meshes[0].materials[0];
        let source = material.diffuse_texture.as_ref().expect("a texture");
        assert_eq!(
            matches!(source, TextureSource::Embedded { .. }),
            embedded,
            "{file}: {source:?}"
        );
        assert!(material.texture_transform.clamp, "{file}: the sampler clamps");
        matte(&mut loaded.model);
        let scene = scene_of(&loaded.model);
        let image = if file == "view.glb" {
            let (gpu, cpu) = render_both(&scene, settings);
            assert_close(&gpu, &cpu, file);
            gpu
        } else {
            cpu_render(&scene, settings)
        };
        let worst = largest_difference(&image, &obj_image);
        assert!(worst < 1e-3, "{file} renders unlike its OBJ twin (largest difference {worst})");
    }
}

/// What the Khronos Duck checked (its eye on its head, not its beak), without the Duck: a
/// textured glTF whose buffer and image are files beside it, the image's four quadrants
/// (red, green / blue, white) where they belong on the quad, neither turned over nor
/// mirrored.
#[test]
fn an_external_texture_is_neither_turned_over_nor_mirrored() {
    let dir = Scratch::new("quadrants");
    let img = image::RgbaImage::from_fn(8, 8, |x, y| {
        image::Rgba(match (x < 4, y < 4) {
            (true, true) => [255, 0, 0, 255],
            (false, true) => [0, 255, 0, 255],
            (true, false) => [0, 0, 255, 255],
            (false, false) => [255, 255, 255, 255],
        })
    });
    img.save(dir.join("quadrants.png")).unwrap();
    std::fs::write(dir.join("quad.bin"), quad_bin()).unwrap();
    let json =
        quad_json(r#"{"uri": "quad.bin", "byteLength": 140}"#, r#"{"uri": "quadrants.png"}"#, "");
    std::fs::write(dir.join("duck.gltf"), json).unwrap();
    let mut loaded = load(&dir.join("duck.gltf"));
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    matte(&mut loaded.model);
    let image =
        cpu_render(&scene_of(&loaded.model), RenderSettings { bounces: 0, ..settings(64, 0) });
    // The quad spans rows and columns 14 to 50; 23 and 41 are its quarters.
    for (x, y, colour, what) in [
        (23, 23, [1.0, 0.0, 0.0], "top left red"),
        (41, 23, [0.0, 1.0, 0.0], "top right green"),
        (23, 41, [0.0, 0.0, 1.0], "bottom left blue"),
        (41, 41, [1.0, 1.0, 1.0], "bottom right white"),
    ] {
        let p = image.get(x, y);
        let matches = (0..3).all(|c| (p[c] > 0.5) == (colour[c] > 0.5));
        assert!(matches, "{what}: pixel ({x}, {y}) is {p:?}");
    }
}

#[test]
fn texture_transforms_and_normalized_texture_coordinates_are_read_in_gltf_space() {
    // Texture coordinates as normalized unsigned bytes: 0 and 255 are 0 and 1.
    let mut bin = f32s(&[0., 0., 0., 1., 0., 0., 0., 1., 0.]);
    bin.extend([0u8, 255, 255, 255, 0, 0, 0, 0]);
    let doc = |transform: &str| {
        format!(
            r#"{{"asset": {{"version": "2.0"}}, "extensionsUsed": ["KHR_texture_transform"], "extensionsRequired": ["KHR_texture_transform"],
  "nodes": [{{"mesh": 0}}], "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "material": 0}}]}}],
  "materials": [{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0{transform}}}}}}}],
  "textures": [{{"source": 0}}], "images": [{{"uri": "data:image/png;base64,AAAA"}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}},
                {{"bufferView": 1, "componentType": 5121, "normalized": true, "count": 3, "type": "VEC2"}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 36}}, {{"buffer": 0, "byteOffset": 36, "byteLength": 8}}],
  "buffers": [{{"uri": "data:application/octet-stream;base64,{}", "byteLength": 44}}]}}"#,
            base64(&bin)
        )
    };
    let plain = parse(&doc(""));
    let uv = &plain.model.meshes[0].texcoords;
    // glTF (0, 1), (1, 1), (0, 0): v turned over to our bottom-left origin.
    assert_eq!(uv, &[Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)]);

    // Offset, then rotation a quarter turn counter-clockwise, then scale, as the extension
    // has them (uv' = T R S uv), in glTF's space, then turned over.
    let transformed = parse(&doc(
        r#", "extensions": {"KHR_texture_transform": {"offset": [0.5, 0.25], "rotation": 1.5707964, "scale": [2, 3]}}"#,
    ));
    let expected = [[0.0f32, 1.0], [1.0, 1.0], [0.0, 0.0]].map(|[u, v]| {
        let (u, v) = (2.0 * u, 3.0 * v); // scale
        let (u, v) = (-v, u); // a quarter turn
        Vec2::new(u + 0.5, 1.0 - (v + 0.25))
    });
    let got = &transformed.model.meshes[0].texcoords;
    for (g, e) in got.iter().zip(expected) {
        assert!((*g - e).length() < 1e-5, "{got:?} vs {expected:?}");
    }
}

#[test]
fn samplers_repeat_or_clamp_and_what_the_tracers_lack_is_warned() {
    let png = two_colour_png();
    let buffer = format!(
        r#"{{"uri": "data:application/octet-stream;base64,{}", "byteLength": 140}}"#,
        base64(&quad_bin())
    );
    let image = format!(r#"{{"uri": "data:image/png;base64,{}"}}"#, base64(&png));
    let doc = quad_json(&buffer, &image, "");
    let with_sampler =
        |sampler: &str| parse(&doc.replace(r#"{"wrapS": 33071, "wrapT": 33071}"#, sampler));
    for (sampler, clamp, warning) in [
        (r#"{"wrapS": 33071, "wrapT": 33071}"#, true, None),
        ("{}", false, None),
        (r#"{"wrapS": 33648}"#, false, Some("mirrored repeat, which is read as repeat")),
        (r#"{"wrapS": 33071}"#, false, Some("clamps in one direction and repeats in the other")),
    ] {
        let loaded = with_sampler(sampler);
        let material = &loaded.model.meshes[0].materials[0];
        assert_eq!(material.texture_transform.clamp, clamp, "{sampler}");
        match warning {
            None => assert!(loaded.warnings.is_empty(), "{sampler}: {:?}", loaded.warnings),
            Some(w) => assert!(
                loaded.warnings.len() == 1 && loaded.warnings[0].contains(w),
                "{sampler}: {:?}",
                loaded.warnings
            ),
        }
    }
}

#[test]
fn alpha_modes_are_not_read_and_say_so() {
    let buffer = format!(
        r#"{{"uri": "data:application/octet-stream;base64,{}", "byteLength": 140}}"#,
        base64(&quad_bin())
    );
    let image = format!(r#"{{"uri": "data:image/png;base64,{}"}}"#, base64(&two_colour_png()));
    let doc = quad_json(&buffer, &image, "");
    for mode in ["MASK", "BLEND"] {
        let masked = doc.replace(
            r#""materials": [{"pbrMetallicRoughness""#,
            &format!(r#""materials": [{{"alphaMode": "{mode}", "alphaCutoff": 0.3, "pbrMetallicRoughness""#),
        );
        let loaded = parse(&masked);
        assert!(
            loaded.warnings.len() == 1
                && loaded.warnings[0].contains(&format!(
                    "has alpha mode {mode}, which is not read: it is drawn opaque"
                )),
            "{:?}",
            loaded.warnings
        );
    }
}

// ---------------------------------------------------------------------------------------
// Accessors

/// A triangle whose POSITION accessor (number 0) is `position`, with `views` and the buffer
/// `bin` as a base64 data URI.
fn triangle_doc(position: &str, views: &str, bin: &[u8], extra: &str) -> String {
    format!(
        r#"{{"asset": {{"version": "2.0"}}{extra},
  "nodes": [{{"mesh": 0}}], "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
  "accessors": [{position}],
  "bufferViews": [{views}],
  "buffers": [{{"uri": "data:application/octet-stream;base64,{}", "byteLength": {}}}]}}"#,
        base64(bin),
        bin.len()
    )
}

#[test]
fn an_accessor_without_a_buffer_view_is_zeros_and_sparse_values_replace_elements() {
    // Sparse substitutions over zeros: vertices 1 and 2 set (u8 indices), vertex 0 stays 0.
    let mut bin = vec![2u8, 1, 0, 0];
    bin.extend(f32s(&[0., 1., 0., 1., 0., 0.]));
    let zeros = triangle_doc(
        r#"{"componentType": 5126, "count": 3, "type": "VEC3", "sparse": {"count": 2,
            "indices": {"bufferView": 0, "componentType": 5121},
            "values": {"bufferView": 1}}}"#,
        r#"{"buffer": 0, "byteLength": 2}, {"buffer": 0, "byteOffset": 4, "byteLength": 24}"#,
        &bin,
        "",
    );
    let mesh = &parse(&zeros).model.meshes[0];
    assert_eq!(mesh.positions, [Vec3::ZERO, Vec3::X, Vec3::Y]);

    // Sparse substitutions over a buffer view: vertex 0 moved from (5, 5, 5) to (0, 0, 1).
    let mut bin = f32s(&[5., 5., 5., 1., 0., 0., 0., 1., 0.]);
    bin.extend([0u16, 0].iter().flat_map(|i| i.to_le_bytes()));
    bin.extend(f32s(&[0., 0., 1.]));
    let over = triangle_doc(
        r#"{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "sparse": {"count": 1,
            "indices": {"bufferView": 1, "componentType": 5123},
            "values": {"bufferView": 2}}}"#,
        r#"{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 2},
           {"buffer": 0, "byteOffset": 40, "byteLength": 12}"#,
        &bin,
        "",
    );
    assert_eq!(parse(&over).model.meshes[0].positions, [Vec3::Z, Vec3::X, Vec3::Y]);

    // A sparse index past the accessor's end breaks the geometry: refused, naming it.
    let mut bin2 = bin.clone();
    bin2[36] = 7;
    let bad = over.replace(&base64(&bin), &base64(&bin2));
    let e = load_gltf_from_bytes(bad.as_bytes(), "bad.gltf", None).unwrap_err().to_string();
    assert!(e.starts_with("bad.gltf") && e.contains("sparse index 7 is out of range"), "{e}");
}

#[test]
fn quantized_positions_and_colours_are_read_as_the_extension_says() {
    // KHR_mesh_quantization: positions as plain i16, scaled back by the node; colours as
    // normalized u16.
    // Three VEC3 of i16 at a stride of 8 (elements padded to four-byte boundaries).
    let mut bin = Vec::new();
    for p in [[0i16, 0, 0], [100, 0, 0], [0, 100, 0]] {
        bin.extend(p.iter().flat_map(|v| v.to_le_bytes()));
        bin.extend([0, 0]);
    }
    for c in [[65535u16, 0, 0], [0, 65535, 0], [0, 0, 32768]] {
        bin.extend(c.iter().flat_map(|v| v.to_le_bytes()));
    }
    bin.extend([0, 0]);
    let doc = format!(
        r#"{{"asset": {{"version": "2.0"}}, "extensionsUsed": ["KHR_mesh_quantization"], "extensionsRequired": ["KHR_mesh_quantization"],
  "nodes": [{{"mesh": 0, "scale": [0.01, 0.01, 0.01]}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "COLOR_0": 1}}}}]}}],
  "accessors": [{{"bufferView": 0, "componentType": 5122, "count": 3, "type": "VEC3"}},
                {{"bufferView": 1, "componentType": 5123, "normalized": true, "count": 3, "type": "VEC3"}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 24, "byteStride": 8}}, {{"buffer": 0, "byteOffset": 24, "byteLength": 18}}],
  "buffers": [{{"uri": "data:application/octet-stream;base64,{}", "byteLength": {}}}]}}"#,
        base64(&bin),
        bin.len()
    );
    let model = parse(&doc).model;
    let mesh = model.flatten();
    for (p, e) in mesh.positions.iter().zip([Vec3::ZERO, Vec3::X, Vec3::Y]) {
        assert!((*p - e).length() < 1e-6, "{p} vs {e}");
    }
    assert_eq!(mesh.colors, [[255, 0, 0, 255], [0, 255, 0, 255], [0, 0, 128, 255]]);
}

#[test]
fn files_the_validator_accepts_are_read_where_the_gltf_crate_was_stricter() {
    // In one file: integers written `3.0`, a texture without `source` (an extension's image),
    // an animation channel target without `node`, a buffer as a percent-encoded data URI.
    let bin = f32s(&[0., 0., 0., 1., 0., 0., 0., 1., 0.]);
    let doc = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0.0, "scenes": [{{"nodes": [0.0]}}],
  "nodes": [{{"mesh": 0.0}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0.0}}, "mode": 4.0, "material": 0}}]}}],
  "materials": [{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}}}}}}],
  "textures": [{{"extensions": {{"EXT_texture_webp": {{"source": 0}}}}}}],
  "images": [{{"uri": "image.webp"}}],
  "animations": [{{"channels": [{{"sampler": 0, "target": {{"path": "translation"}}}}], "samplers": [{{"input": 0, "output": 0}}]}}],
  "accessors": [{{"bufferView": 0.0, "componentType": 5126.0, "count": 3.0, "type": "VEC3"}}],
  "bufferViews": [{{"buffer": 0.0, "byteLength": 36.0}}],
  "buffers": [{{"uri": "data:application/octet-stream,{}", "byteLength": 36}}]}}"#,
        percent_encoded(&bin)
    );
    let loaded = parse(&doc);
    assert_eq!(loaded.model.meshes[0].positions, [Vec3::ZERO, Vec3::X, Vec3::Y]);
    assert_eq!(loaded.model.meshes[0].materials[0].diffuse_texture, None);
    assert!(
        loaded.warnings.len() == 1 && loaded.warnings[0].contains("has no image meshtracer reads"),
        "{:?}",
        loaded.warnings
    );
}

// ---------------------------------------------------------------------------------------
// Nodes as instances

/// An L of three triangles (no symmetry a rotation could hide), positions only.
fn l_shape_bin() -> Vec<u8> {
    f32s(&[
        0., 0., 0., 1., 0., 0., 1., 0.4, 0., //
        0., 0., 0., 1., 0.4, 0., 0., 0.4, 0., //
        0., 0.4, 0., 0.4, 0.4, 0., 0., 1.2, 0.2,
    ])
}

/// `nodes` (JSON) over mesh 0 (the L) and mesh 1 (one triangle), scene 0 drawing `roots`;
/// scene 1 holds node `extra` if any.
fn nodes_doc(nodes: &str, roots: &str) -> String {
    let bin = l_shape_bin();
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": {roots}}}, {{"nodes": [0]}}],
  "nodes": {nodes},
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}, {{"primitives": [{{"attributes": {{"POSITION": 1}}}}]}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 9, "type": "VEC3"}},
                {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 108}}],
  "buffers": [{{"uri": "data:application/octet-stream;base64,{}", "byteLength": 108}}]}}"#,
        base64(&bin)
    )
}

#[test]
fn a_shared_mesh_is_stored_once_and_each_node_places_it() {
    // Node 1 (a root, mesh 0) turns a quarter about y and moves; its child 2 moves up;
    // child 3 (no mesh) is a matrix turning about x at half scale, over node 4 (mesh 0)
    // moved along z. Node 0 (mesh 1) is only in scene 1, so mesh 1 is not stored.
    let turn_x = Mat4::from_scale_rotation_translation(
        Vec3::splat(0.5),
        Quat::from_rotation_x(1.0),
        Vec3::new(0.0, 0.0, -1.0),
    );
    let nodes = format!(
        r#"[{{"mesh": 1}},
  {{"mesh": 0, "rotation": [0, 0.70710677, 0, 0.70710677], "translation": [1, 0, 0], "children": [2, 3]}},
  {{"mesh": 0, "translation": [0, 2, 0]}},
  {{"matrix": {:?}, "children": [4]}},
  {{"mesh": 0, "translation": [0, 0, 1], "scale": [1, -1, 1]}}]"#,
        turn_x.to_cols_array()
    );
    let loaded = parse(&nodes_doc(&nodes, "[1]"));
    let model = &loaded.model;
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    assert_eq!(model.meshes.len(), 1, "mesh 0 once; mesh 1 is in no node of the scene");
    assert_eq!(model.meshes[0].triangle_count(), 3);
    let node1 = Mat4::from_rotation_translation(
        Quat::from_rotation_y(std::f32::consts::FRAC_PI_2),
        Vec3::X,
    );
    let expected = [
        node1,
        node1 * Mat4::from_translation(Vec3::new(0.0, 2.0, 0.0)),
        node1
            * turn_x
            * Mat4::from_scale_rotation_translation(
                Vec3::new(1.0, -1.0, 1.0),
                Quat::IDENTITY,
                Vec3::Z,
            ),
    ];
    assert_eq!(model.parts.len(), expected.len());
    for (part, e) in model.parts.iter().zip(expected) {
        assert_eq!(part.mesh, 0);
        assert!(
            part.transform.abs_diff_eq(Affine3A::from_mat4(e), 1e-5),
            "{:?} vs {e:?}",
            part.transform
        );
    }
    assert_eq!(model.triangle_count(), 9);

    // Fitted and traced: GPU = CPU, and the same image as the flattened twin (one mesh of
    // nine triangles, the mirrored part's winding turned back).
    let mut model = loaded.model;
    prepare_model(&mut model);
    let settings = settings(48, 1);
    // Seen from the side: node 1's quarter turn sets the parts edge-on to +z.
    let aside = |mut scene: Scene| {
        scene.camera.position = Vec3::new(2.6, 0.8, 1.2);
        scene.light.position = scene.camera.position;
        scene
    };
    let instanced = aside(scene_of(&model));
    let (gpu, cpu) = render_both(&instanced, settings);
    assert_close(&gpu, &cpu, "instanced nodes");
    assert_vendor_matches(&instanced, settings, &gpu);
    let flat = Model::from(model.flatten());
    assert_eq!(flat.meshes[0].triangle_count(), 9);
    let twin = cpu_render(&aside(scene_of(&flat)), settings);
    // Different arithmetic (rays carried into the mesh's space, against vertices moved into
    // the world's): the tolerance of two tracers.
    assert_within(&cpu, &twin, tolerance::VENDOR, "instanced nodes against the flattened twin");
    let lit = cpu.pixels.iter().filter(|p| p[0] > 0.0).count();
    // The three thin Ls cover about 40 pixels each when seen face-on.
    assert!(lit > 40, "the model is in view ({lit} pixels)");
}

/// The vendor's structures (every kernel the device has) trace `scene` as ours did (`ours`).
fn assert_vendor_matches(scene: &Scene, settings: RenderSettings, ours: &Image) {
    let ctx = ctx();
    let support = &ctx.info.vendor;
    if !require(support.available(), "the vendor's ray tracing is missing") {
        return;
    }
    let mut tracer = ComputeTracer::with_scene(&ctx, &PackedScene::new(scene)).expect("upload");
    for kernel in VendorKernel::ALL.into_iter().filter(|k| k.supported(support)) {
        tracer.set_vendor_kernel(kernel).expect("a kind the device has");
        let vendor = RenderSettings { accel: Accel::Vendor, ..settings };
        let (image, _) = tracer.render(&FrameParams::new(scene, vendor)).expect("trace");
        assert_within(&image, ours, tolerance::VENDOR, &format!("nodes, vendor's {kernel}"));
    }
    drop(tracer);
    assert_validation_clean(&ctx);
}

/// Bytes of device memory `scene` takes on the GPU.
fn gpu_bytes(scene: &Scene) -> u64 {
    let ctx = ctx();
    let tracer = ComputeTracer::with_scene(&ctx, &PackedScene::new(scene)).expect("upload");
    let bytes = tracer.scene_bytes();
    drop(tracer);
    assert_validation_clean(&ctx);
    bytes
}

#[test]
fn a_thousand_nodes_of_one_mesh_hold_one_mesh_and_a_thousand_transforms() {
    let nodes: Vec<String> = (0..1000)
        .map(|i| {
            let q = Quat::from_rotation_y(i as f32 * 0.1);
            format!(
                r#"{{"mesh": 0, "rotation": [{}, {}, {}, {}], "translation": [{}, {}, 0]}}"#,
                q.x,
                q.y,
                q.z,
                q.w,
                (i % 40) as f32 * 2.0,
                (i / 40) as f32 * 2.0
            )
        })
        .collect();
    let roots: Vec<String> = (0..1000).map(|i| i.to_string()).collect();
    let loaded =
        parse(&nodes_doc(&format!("[{}]", nodes.join(",")), &format!("[{}]", roots.join(","))));
    let mut model = loaded.model;
    assert_eq!(model.meshes.len(), 1);
    assert_eq!(model.meshes[0].triangle_count(), 3, "the mesh is stored once");
    assert_eq!(model.meshes[0].vertex_count(), 9);
    assert_eq!(model.parts.len(), 1000);
    assert_eq!(model.triangle_count(), 3000, "placed a thousand times");
    prepare_model(&mut model);
    let scene = scene_of(&model);
    let packed = PackedScene::new(&scene);
    assert_eq!(packed.meshes.len(), 1);
    assert!(packed.triangles.len() < 3 * 4, "{} triangle slots packed", packed.triangles.len());
    assert_eq!(scene.instances.len(), 1000);

    // On the host and the GPU: the same mesh placed once and a thousand times differ by
    // the thousand placements (instance records and the top level, whose buffers are made
    // for thousands of copies up front, so the difference may be nothing), never by copies
    // of the mesh. Checked with a mesh of 20,000 triangles, which a copy per node would show.
    let big = big_mesh_doc(20_000);
    let one = parse(&big.replace(r#""NODES""#, r#"[{"mesh": 0}]"#));
    let nodes: Vec<String> = (0..1000)
        .map(|i| format!(r#"{{"mesh": 0, "translation": [{}, {}, 0]}}"#, i % 40, i / 40))
        .collect();
    let thousand = parse(&big.replace(r#""NODES""#, &format!("[{}]", nodes.join(","))));
    let [one, thousand] = [one, thousand].map(|l| {
        let mut model = l.model;
        prepare_model(&mut model);
        scene_of(&model)
    });
    assert_eq!(thousand.instances.len(), 1000);
    let packed = [&one, &thousand].map(|s| PackedScene::new(s).triangles.len());
    assert_eq!(packed[0], packed[1], "triangle slots on the host");
    let (one_bytes, thousand_bytes) = (gpu_bytes(&one), gpu_bytes(&thousand));
    assert!(one_bytes > 20_000 * 36, "the mesh is on the GPU: {one_bytes} bytes");
    let per_node = thousand_bytes.saturating_sub(one_bytes) / 999;
    assert!(
        per_node < 1024,
        "{per_node} bytes per node ({one_bytes} for one, {thousand_bytes} for 1,000)"
    );
}

/// A document whose mesh 0 is `n` separate triangles (positions only, no two alike) and
/// whose nodes are the placeholder `"NODES"`, all in scene 0.
fn big_mesh_doc(n: usize) -> String {
    let values: Vec<f32> = (0..n)
        .flat_map(|i| {
            let (x, y) = ((i % 200) as f32 * 0.01, (i / 200) as f32 * 0.01);
            [x, y, 0.0, x + 0.008, y, 0.0, x, y + 0.008, 0.001 * (i % 7) as f32]
        })
        .collect();
    let bin = f32s(&values);
    let nodes = r#""nodes": "NODES""#;
    format!(
        r#"{{"asset": {{"version": "2.0"}}, {nodes},
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": {}, "type": "VEC3"}}],
  "bufferViews": [{{"buffer": 0, "byteLength": {}}}],
  "buffers": [{{"uri": "data:application/octet-stream;base64,{}", "byteLength": {}}}]}}"#,
        3 * n,
        bin.len(),
        base64(&bin),
        bin.len()
    )
}

// ---------------------------------------------------------------------------------------
// Refusals

#[test]
fn each_refusal_is_one_line_naming_the_file_and_what() {
    let dir = Scratch::new("refusals");
    let bin = l_shape_bin();
    let l_shape = |extra: &str| {
        triangle_doc(
            r#"{"bufferView": 0, "componentType": 5126, "count": 9, "type": "VEC3"}"#,
            r#"{"buffer": 0, "byteLength": 108}"#,
            &bin,
            extra,
        )
    };
    let cases = [
        (
            "instancing.gltf",
            l_shape(
                r#", "extensionsUsed": ["EXT_mesh_gpu_instancing"], "extensionsRequired": ["EXT_mesh_gpu_instancing"]"#,
            ),
            "needs `EXT_mesh_gpu_instancing`, which meshtracer does not read",
        ),
        (
            "version.gltf",
            l_shape("").replace(r#""version": "2.0""#, r#""version": "1.0""#),
            "a glTF of version 1.0 (only 2.x is read)",
        ),
        (
            "zeros.gltf",
            triangle_doc(
                r#"{"componentType": 5126, "count": 4000000000, "type": "VEC3"}"#,
                r#"{"buffer": 0, "byteLength": 108}"#,
                &bin,
                "",
            ),
            "more than 268435456 vertices",
        ),
        (
            "sparse zeros.gltf",
            triangle_doc(
                r#"{"componentType": 5126, "count": 20000000, "type": "VEC3"}"#,
                r#"{"buffer": 0, "byteLength": 108}"#,
                &bin,
                "",
            ),
            "accessor 0 (POSITION) has 20000000 elements and no buffer view",
        ),
        (
            "mesh.gltf",
            l_shape("").replace(r#""nodes": [{"mesh": 0}]"#, r#""nodes": [{"mesh": 5}]"#),
            "node 0 uses mesh 5, but the file has 1 meshes",
        ),
        (
            "cycle.gltf",
            l_shape(r#", "scenes": [{"nodes": [0]}]"#)
                .replace(r#""nodes": [{"mesh": 0}]"#, r#""nodes": [{"mesh": 0, "children": [0]}]"#),
            "the node hierarchy is deeper than 64",
        ),
        (
            "lines.gltf",
            l_shape("").replace(
                r#""attributes": {"POSITION": 0}"#,
                r#""attributes": {"POSITION": 0}, "mode": 1"#,
            ),
            "the default scene has no triangles",
        ),
        ("object.gltf", "[1, 2]".to_owned(), "the document is not a JSON object"),
    ];
    for (name, text, expected) in cases {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        let e = load_model(&ModelSource::File(path.clone()), &LoadOptions::default(), None)
            .err()
            .unwrap_or_else(|| panic!("{name} loads"))
            .to_string();
        assert!(e.starts_with(&path.display().to_string()), "{name}: {e}");
        assert!(e.contains(expected), "{name}: {e}");
        assert!(!e.contains('\n'), "{name}: {e}");
    }
}

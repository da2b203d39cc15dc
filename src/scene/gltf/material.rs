//! A glTF metallic-roughness material as our Blinn–Phong one, with its base colour texture:
//! the image from a file beside the model, a buffer view or a `data:` URI, the sampler's
//! wrap mode and the `KHR_texture_transform` that lays it on.

use std::path::Path;
use std::sync::Arc;

use glam::{Affine2, Vec2, Vec3};
use serde_json::Value as Json;

use super::doc::{array, number, numbers, uint, Doc};
use super::{decode_data_uri, percent_decode};
use crate::scene::{Material, TextureSource};

/// `wrapS`/`wrapT` codes (WebGL's).
const CLAMP_TO_EDGE: usize = 33071;
const MIRRORED_REPEAT: usize = 33648;

/// A material as converted, with what its texture needs of the primitives' vertices.
#[derive(Clone, Debug)]
pub(super) struct Converted {
    pub material: Material,
    /// Which `TEXCOORD_n` the base colour texture reads.
    pub texcoord: usize,
    /// `KHR_texture_transform` in glTF's texture space, baked into the primitives' texture
    /// coordinates at load (exact: the transform is affine, so it commutes with the
    /// interpolation across a triangle), so rotation needs nothing of the shaders.
    pub uv_transform: Option<Affine2>,
}

/// Our material for glTF material `index` (None: the primitive has none, and gets our
/// default, which the model's look replaces). Metallic-roughness maps onto Blinn–Phong as
/// README's formats table states: base colour (factor times texture) is the diffuse colour;
/// the highlight is 4% grey for dielectrics and the base colour for metals; roughness sets
/// the exponent (`2 / α² - 2` with `α = roughness²`); metallic is the mirror blend.
/// Anything unreadable is a warning, and the material keeps its plain colour.
pub(super) fn convert_material(
    doc: &Doc,
    index: Option<usize>,
    name: &str,
    base_dir: Option<&Path>,
    warnings: &mut Vec<String>,
) -> Converted {
    let plain = Converted { material: Material::default(), texcoord: 0, uv_transform: None };
    let Some(index) = index else { return plain };
    let Some(m) = array(doc.root, "materials").get(index) else {
        warnings.push(format!("{name}: a primitive uses material {index}, which the file does not have; it gets the default material"));
        return plain;
    };
    let label = m.get("name").and_then(Json::as_str).map_or_else(
        || format!("material {index}"),
        |n| crate::files::shown(n, crate::files::MAX_QUOTED_NAME),
    );
    let empty = Json::Null;
    let pbr = m.get("pbrMetallicRoughness").unwrap_or(&empty);
    let factor = numbers::<4>(pbr, "baseColorFactor").unwrap_or([1.0; 4]);
    let base = Vec3::new(factor[0], factor[1], factor[2]);
    let base = if base.is_finite() { base.clamp(Vec3::ZERO, Vec3::ONE) } else { Vec3::ONE };
    let unit = |key: &str| {
        number(pbr, key).filter(|v| v.is_finite()).map_or(1.0, |v| v.clamp(0.0, 1.0) as f32)
    };
    let (metal, roughness) = (unit("metallicFactor"), unit("roughnessFactor"));
    // Cut-outs and transparency would cost the traversal a texture read per candidate hit.
    let alpha_mode = m.get("alphaMode").and_then(Json::as_str).unwrap_or("OPAQUE");
    if alpha_mode != "OPAQUE" {
        warnings.push(format!(
            "{name}: {label} has alpha mode {}, which is not read: it is drawn opaque",
            crate::files::shown(alpha_mode, 20)
        ));
    }
    let alpha = roughness.max(0.01).powi(2);
    let mut out = Converted {
        material: Material {
            name: label.clone(),
            diffuse: base,
            specular: Vec3::splat(0.04).lerp(base, metal),
            shininess: (2.0 / (alpha * alpha) - 2.0).clamp(1.0, 1024.0),
            mirror: metal,
            ..Material::default()
        },
        ..plain
    };
    if let Some(info) = pbr.get("baseColorTexture") {
        let texture = Texture { doc, name, base_dir, label: &label };
        match texture.read(info, &mut out, warnings) {
            Ok(()) => {}
            Err(why) => warnings.push(format!(
                "{name}: the base colour texture of {label} {why}; the material keeps its plain colour"
            )),
        }
    }
    out
}

/// What reading one material's texture needs.
struct Texture<'a> {
    doc: &'a Doc<'a>,
    name: &'a str,
    base_dir: Option<&'a Path>,
    label: &'a str,
}

impl Texture<'_> {
    /// The texture `info` (a textureInfo) names, into `out`; an error is the end of a
    /// sentence that begins with the texture ("is ...", "has ..."), for the warning.
    fn read(
        &self,
        info: &Json,
        out: &mut Converted,
        warnings: &mut Vec<String>,
    ) -> Result<(), String> {
        let what = format!("the base colour texture of {}", self.label);
        let index = uint(info, "index", &what).ok().flatten().ok_or("has no texture index")?;
        let texture = array(self.doc.root, "textures")
            .get(index)
            .ok_or(format!("is texture {index}, which the file does not have"))?;
        let source = uint(texture, "source", &what).ok().flatten().ok_or(
            "has no image meshtracer reads (no `source`; an extension's image format, such as KTX2 or WebP, is not read)",
        )?;
        let image = array(self.doc.root, "images")
            .get(source)
            .ok_or(format!("is image {source}, which the file does not have"))?;
        let source = self.image_source(source, image)?;
        let transform = info.pointer("/extensions/KHR_texture_transform");
        out.texcoord = transform
            .and_then(|t| uint(t, "texCoord", &what).ok().flatten())
            .or_else(|| uint(info, "texCoord", &what).ok().flatten())
            .unwrap_or(0);
        out.uv_transform = transform.map(|t| {
            let offset = numbers::<2>(t, "offset").unwrap_or([0.0; 2]);
            let scale = numbers::<2>(t, "scale").unwrap_or([1.0; 2]);
            let rotation = number(t, "rotation").unwrap_or(0.0) as f32;
            // The extension's `translation * rotation * scale` (rotation counter-clockwise).
            Affine2::from_scale_angle_translation(Vec2::from(scale), rotation, Vec2::from(offset))
        });
        if out.uv_transform.is_some_and(|t| !t.is_finite()) {
            warnings.push(format!(
                "{}: the texture transform of {} is not finite; ignored",
                self.name, self.label
            ));
            out.uv_transform = None;
        }
        out.material.texture_transform.clamp = self.clamps(texture, warnings);
        out.material.diffuse_texture = Some(source);
        Ok(())
    }

    /// The image's bytes or file: a buffer view, a `data:` URI or a file beside the model.
    fn image_source(&self, index: usize, image: &Json) -> Result<TextureSource, String> {
        let shown_name = image
            .get("name")
            .and_then(Json::as_str)
            .map(|n| format!(" `{}`", crate::files::shown(n, crate::files::MAX_QUOTED_NAME)))
            .unwrap_or_default();
        let embedded = |bytes: Vec<u8>| TextureSource::Embedded {
            name: format!("image {index}{shown_name} of {}", self.name),
            bytes: Arc::from(bytes),
        };
        if let Some(uri) = image.get("uri").and_then(Json::as_str) {
            if uri.starts_with("data:") {
                return decode_data_uri(uri)
                    .map(embedded)
                    .ok_or("has a data URI that cannot be decoded".to_owned());
            }
            let shown = crate::files::shown(uri, 200);
            let dir = self
                .base_dir
                .ok_or(format!("is the file `{shown}`, which cannot be read here (no folder)"))?;
            let path = dir.join(percent_decode(uri));
            // A FIFO or device is refused here, by name, as well as when the image is read.
            return match crate::files::regular_file_size(&path, "the image") {
                Ok(_) => Ok(TextureSource::File(path)),
                // The reason after the path: "no such file or directory", "not a regular
                // file" (a FIFO or device, never opened)...
                Err(e) => match e.rsplit(": ").next().unwrap_or_default() {
                    "no such file or directory" => {
                        Err(format!("is the file `{shown}`, which is not found"))
                    }
                    why => Err(format!("is the file `{shown}`, which cannot be read ({why})")),
                },
            };
        }
        let view = uint(image, "bufferView", &format!("image {index}"))
            .ok()
            .flatten()
            .ok_or("has an image with neither a uri nor a bufferView")?;
        let bytes = self.doc.buffer_view(view, &format!("image {index}"))?;
        Ok(embedded(bytes.to_vec()))
    }

    /// Whether the texture's sampler clamps (both directions CLAMP_TO_EDGE). Our tracers
    /// repeat or clamp both directions alike and do not mirror: the nearest is taken, warned.
    fn clamps(&self, texture: &Json, warnings: &mut Vec<String>) -> bool {
        let sampler = uint(texture, "sampler", "texture")
            .ok()
            .flatten()
            .and_then(|s| array(self.doc.root, "samplers").get(s));
        let Some(sampler) = sampler else { return false };
        let wrap = |key| uint(sampler, key, "sampler").ok().flatten().unwrap_or(10497);
        let (s, t) = (wrap("wrapS"), wrap("wrapT"));
        if s == MIRRORED_REPEAT || t == MIRRORED_REPEAT {
            warnings.push(format!(
                "{}: the texture of {} has a mirrored repeat, which is read as repeat",
                self.name, self.label
            ));
        }
        match (s == CLAMP_TO_EDGE, t == CLAMP_TO_EDGE) {
            (true, true) => true,
            (false, false) => false,
            _ => {
                warnings.push(format!("{}: the texture of {} clamps in one direction and repeats in the other; it repeats in both", self.name, self.label));
                false
            }
        }
    }
}

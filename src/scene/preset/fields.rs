//! The preset's fields as TOML spells them: models and environments as their flags write
//! them, and the deserializers that hold each number to its flag's range (a bad value is
//! the key's error, so the message names the key and the line).

use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serializer};

use super::VERSION;
use crate::render_settings as knobs;
use crate::scene::paper::ModelSource;
use crate::scene::EnvironmentSource;

pub(super) fn ser_model<S: Serializer>(m: &ModelSource, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&model_arg(m))
}

pub(super) fn ser_env<S: Serializer>(
    e: &Option<EnvironmentSource>,
    s: S,
) -> Result<S::Ok, S::Error> {
    s.serialize_str(&env_arg(e))
}

pub(super) fn ser_display<T: std::fmt::Display, S: Serializer>(
    v: &T,
    s: S,
) -> Result<S::Ok, S::Error> {
    s.serialize_str(v.to_string().trim())
}

pub(super) fn de_from_str<'de, T: std::str::FromStr<Err = String>, D: Deserializer<'de>>(
    d: D,
) -> Result<T, D::Error> {
    String::deserialize(d)?.parse().map_err(D::Error::custom)
}

pub(super) fn de_model<'de, D: Deserializer<'de>>(d: D) -> Result<ModelSource, D::Error> {
    let text = String::deserialize(d)?;
    if text.trim().is_empty() {
        return Err(D::Error::custom("no model given (a model name, torusknot:N or an .obj path)"));
    }
    let model = ModelSource::parse(text.trim());
    model.check_name().map_err(D::Error::custom)?;
    Ok(model)
}

pub(super) fn de_env<'de, D: Deserializer<'de>>(
    d: D,
) -> Result<Option<EnvironmentSource>, D::Error> {
    let text = String::deserialize(d)?;
    if text.trim().is_empty() {
        return Err(D::Error::custom("no environment given (none, sky or an image path)"));
    }
    Ok(EnvironmentSource::parse(text.trim()))
}

pub(super) fn de_in_range<'de, D: Deserializer<'de>>(
    d: D,
    range: knobs::Range,
) -> Result<u32, D::Error> {
    let n = i64::deserialize(d)?;
    range.check(n as f64, n).map_err(D::Error::custom)?;
    Ok(n as u32)
}

pub(super) fn de_finite_in<'de, D: Deserializer<'de>>(
    d: D,
    range: knobs::Range,
) -> Result<f32, D::Error> {
    let v = f64::deserialize(d)?;
    if !v.is_finite() {
        return Err(D::Error::custom(format!("{v} is not a finite number")));
    }
    // In range before narrowing: 1e308 is out of range, not "inf".
    range.check(v, number_text(v)).map_err(D::Error::custom)?;
    Ok(v as f32)
}

pub(super) fn de_light_radius<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    de_finite_in(d, knobs::LIGHT_RADIUS)
}

pub(super) fn de_light_height<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    de_finite_in(d, knobs::LIGHT_HEIGHT)
}

pub(super) fn de_version<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    let v = i64::deserialize(d)?;
    if v == VERSION as i64 {
        Ok(VERSION)
    } else {
        Err(D::Error::custom(format!(
            "format version {v} is not one this meshtracer reads (it reads version {VERSION})"
        )))
    }
}

pub(super) fn de_copies<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    de_in_range(d, knobs::MODELS)
}

pub(super) fn de_side<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    de_in_range(d, knobs::RESOLUTION)
}

pub(super) fn de_bounces<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    de_in_range(d, knobs::BOUNCES)
}

pub(super) fn is_zero(n: &u32) -> bool {
    *n == 0
}

pub(super) fn is_one(n: &u32) -> bool {
    *n == 1
}

pub(super) fn de_accumulate<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    de_in_range(d, knobs::ACCUMULATE)
}

pub(super) fn de_spp<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    de_in_range(d, knobs::SPP)
}

pub(super) fn de_ao_samples<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    de_in_range(d, knobs::AO_SAMPLES)
}

pub(super) fn de_ao_radius<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    de_finite_in(d, knobs::AO_RADIUS)
}

pub(super) fn de_crease_angle<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f32>, D::Error> {
    de_finite_in(d, knobs::CREASE_ANGLE_DEGREES).map(Some)
}

pub(super) fn de_finite<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    let v = f64::deserialize(d)?;
    let narrow = v as f32;
    if !v.is_finite() {
        Err(D::Error::custom(format!("{v} is not a finite number")))
    } else if !narrow.is_finite() {
        Err(D::Error::custom(format!("{} is too large (at most about 3.4e38)", number_text(v))))
    } else {
        Ok(narrow)
    }
}

/// A number as a message shows it: 1e308 as "1e308", not three hundred digits.
pub(super) fn number_text(v: f64) -> String {
    if v.abs() >= 1e9 {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

pub(super) fn de_blend<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    de_finite_in(d, knobs::BLEND)
}

pub(super) fn de_fov<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    de_finite_in(d, knobs::FOV_DEGREES)
}

pub(super) fn de_point<'de, D: Deserializer<'de>>(d: D) -> Result<[f32; 3], D::Error> {
    let v = Vec::<f32>::deserialize(d)?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([x, y, z]),
        [_, _, _] => Err(D::Error::custom("the coordinates must be finite numbers")),
        _ => Err(D::Error::custom(format!("expected [x, y, z], got {} number(s)", v.len()))),
    }
}

/// The `--model` spelling of a model source (what [`ModelSource::parse`] reads back).
pub(super) fn model_arg(model: &ModelSource) -> String {
    match model {
        ModelSource::Paper(m) => m.name().to_string(),
        ModelSource::Generated(n) => format!("torusknot:{n}"),
        ModelSource::File(p) => p.display().to_string(),
    }
}

/// The `--env` spelling of an environment (what [`EnvironmentSource::parse`] reads back).
pub(super) fn env_arg(env: &Option<EnvironmentSource>) -> String {
    match env {
        None => "none".into(),
        Some(EnvironmentSource::Sky) => "sky".into(),
        Some(EnvironmentSource::File(p)) => p.display().to_string(),
    }
}

/// An object's `scale`: one number (uniform) or `[x, y, z]`; finite and not zero (a zero
/// scale flattens the object: the transform check says so in full).
pub(super) fn de_scale<'de, D: Deserializer<'de>>(d: D) -> Result<[f32; 3], D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Scale {
        Uniform(f32),
        PerAxis(Vec<f32>),
    }
    let v = match Scale::deserialize(d)? {
        Scale::Uniform(s) => vec![s; 3],
        Scale::PerAxis(v) => v,
    };
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite() && *c != 0.0) => Ok([x, y, z]),
        [_, _, _] => Err(D::Error::custom("a scale must be a finite number other than 0")),
        _ => Err(D::Error::custom(format!(
            "expected a number or [x, y, z], got {} number(s)",
            v.len()
        ))),
    }
}

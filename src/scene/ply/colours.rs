//! Vertex colours of a PLY file: the properties `red green blue` (also spelt `r g b` or
//! `diffuse_red diffuse_green diffuse_blue`) and an optional `alpha`, kept as RGBA8 as the
//! file stores them. Integers are stored as they are (0..255; `ushort` scaled from
//! 0..65535), floats are 0..1 scaled to 0..255, rounded; anything outside is clamped.

use super::{quote, Element, Property, Scalar};

const RED: &[&str] = &["red", "r", "diffuse_red"];
const GREEN: &[&str] = &["green", "g", "diffuse_green"];
const BLUE: &[&str] = &["blue", "b", "diffuse_blue"];
const ALPHA: &[&str] = &["alpha", "a", "diffuse_alpha"];

/// Where a vertex record's colour is: the red, green, blue and (optional) alpha
/// properties, each with its type.
#[derive(Clone, Copy, Debug)]
pub(super) struct ColourColumns {
    rgb: [(usize, Scalar); 3],
    alpha: Option<(usize, Scalar)>,
}

impl ColourColumns {
    /// The colour properties of `vertex`: None without all three of red, green and blue;
    /// an error (the sentence) when one of them is a list.
    pub(super) fn of(vertex: &Element) -> Result<Option<Self>, String> {
        let column = |names: &[&str]| -> Result<Option<(usize, Scalar)>, String> {
            match vertex
                .properties
                .iter()
                .enumerate()
                .find(|(_, (n, _))| names.contains(&n.as_str()))
            {
                None => Ok(None),
                Some((k, (_, Property::Scalar(s)))) => Ok(Some((k, *s))),
                Some((_, (n, Property::List { .. }))) => Err(format!(
                    "`element vertex` property {} is a list; a colour component must be one value",
                    quote(n)
                )),
            }
        };
        let (r, g, b, alpha) = (column(RED)?, column(GREEN)?, column(BLUE)?, column(ALPHA)?);
        Ok(match (r, g, b) {
            (Some(r), Some(g), Some(b)) => Some(ColourColumns { rgb: [r, g, b], alpha }),
            _ => None,
        })
    }

    /// A record's colour, `value(k)` giving its property `k` (as the reader widened it to f64).
    pub(super) fn rgba(&self, value: impl Fn(usize) -> f64) -> [u8; 4] {
        let [r, g, b] = self.rgb.map(|(k, kind)| byte(value(k), kind));
        [r, g, b, self.alpha.map_or(255, |(k, kind)| byte(value(k), kind))]
    }
}

/// One colour component as a byte.
fn byte(v: f64, kind: Scalar) -> u8 {
    // NaN clamps to NaN, which `as` turns into 0: no panic on any value.
    match kind {
        Scalar::F32 | Scalar::F64 => (v.clamp(0.0, 1.0) * 255.0).round() as u8,
        Scalar::U16 => (v / 257.0).round() as u8,
        _ => v.clamp(0.0, 255.0) as u8,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn components_scale_round_and_clamp() {
        assert_eq!(
            [0.0, 1.0, 0.5, -3.0, 7.0, f64::NAN].map(|v| byte(v, Scalar::F32)),
            [0, 255, 128, 0, 255, 0]
        );
        assert_eq!([0.0, 200.0, 255.0].map(|v| byte(v, Scalar::U8)), [0, 200, 255]);
        assert_eq!([0.0, 65535.0, 257.0 * 9.0].map(|v| byte(v, Scalar::U16)), [0, 255, 9]);
        assert_eq!([-5.0, 300.0].map(|v| byte(v, Scalar::I32)), [0, 255]);
    }
}

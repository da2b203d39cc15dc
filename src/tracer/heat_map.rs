//! Heat maps for the cost and sample-count views: values mapped to an inferno-like scale
//! whose top is the frame's 99th percentile, so a few extreme pixels do not wash it out.

const STOPS: [(f32, [f32; 3]); 5] = [
    (0.0, [0.0, 0.0, 4.0]),
    (0.25, [87.0, 16.0, 110.0]),
    (0.5, [188.0, 55.0, 84.0]),
    (0.75, [249.0, 142.0, 9.0]),
    (1.0, [252.0, 255.0, 164.0]),
];

/// The heat colour of `t` in [0, 1] (clamped; NaN is the bottom).
pub fn heat_color(t: f32) -> [u8; 3] {
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
    let i = STOPS.iter().position(|s| s.0 >= t).unwrap_or(STOPS.len() - 1).max(1);
    let (t0, c0) = STOPS[i - 1];
    let (t1, c1) = STOPS[i];
    let f = (t - t0) / (t1 - t0);
    [0, 1, 2].map(|k| (c0[k] + (c1[k] - c0[k]) * f).round() as u8)
}

/// A heat map of one value per pixel.
pub struct HeatMap {
    /// RGBA bytes, row 0 at the top.
    pub rgba: Vec<u8>,
    /// The value shown as the top of the scale (99th percentile).
    pub scale_max: f32,
    /// The largest value.
    pub max: f32,
    /// Mean over the pixels.
    pub mean: f32,
}

/// Map `values` (one per pixel) to heat colours.
pub fn heat_map(values: &[f32]) -> HeatMap {
    let values: Vec<f32> =
        values.iter().map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 }).collect();
    let max = values.iter().copied().fold(0.0, f32::max);
    let mean = if values.is_empty() {
        0.0
    } else {
        (values.iter().map(|&v| v as f64).sum::<f64>() / values.len() as f64) as f32
    };
    let scale_max = if values.is_empty() {
        0.0
    } else {
        let mut sorted = values.clone();
        let k = ((sorted.len() - 1) as f64 * 0.99).ceil() as usize;
        let (_, kth, _) = sorted.select_nth_unstable_by(k, f32::total_cmp);
        kth.max(1e-6)
    };
    let rgba = values.iter().flat_map(|&v| {
        let [r, g, b] = heat_color(v / scale_max);
        [r, g, b, 255]
    });
    HeatMap { rgba: rgba.collect(), scale_max, max, mean }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ends_of_the_scale() {
        assert_eq!(heat_color(0.0), [0, 0, 4]);
        assert_eq!(heat_color(1.0), [252, 255, 164]);
        assert_eq!(heat_color(f32::NAN), [0, 0, 4]);
    }

    #[test]
    fn percentile_scale_ignores_one_outlier() {
        let mut v = vec![10.0; 1000];
        v[0] = 1e6;
        let h = heat_map(&v);
        assert_eq!(h.scale_max, 10.0);
        assert_eq!(h.max, 1e6);
        assert_eq!(&h.rgba[4..7], &heat_color(1.0));
    }
}

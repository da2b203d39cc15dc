//! The cost heat map: the `Aov::Cost` float output (x = BVH nodes visited, y = triangles
//! tested, summed over the pixel's rays) mapped to an inferno-like colour scale whose top
//! is the frame's 99th percentile, so a few expensive pixels do not wash the map out.

use super::state::CostMetric;

const STOPS: [(f32, [f32; 3]); 5] = [
    (0.0, [0.0, 0.0, 4.0]),
    (0.25, [87.0, 16.0, 110.0]),
    (0.5, [188.0, 55.0, 84.0]),
    (0.75, [249.0, 142.0, 9.0]),
    (1.0, [252.0, 255.0, 164.0]),
];

/// The heat colour of `t` in [0, 1] (clamped).
pub fn heat_color(t: f32) -> [u8; 3] {
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
    let i = STOPS.iter().position(|s| s.0 >= t).unwrap_or(STOPS.len() - 1).max(1);
    let (t0, c0) = STOPS[i - 1];
    let (t1, c1) = STOPS[i];
    let f = (t - t0) / (t1 - t0);
    [0, 1, 2].map(|k| (c0[k] + (c1[k] - c0[k]) * f).round() as u8)
}

/// A heat map of one frame.
pub struct HeatMap {
    /// RGBA bytes, row 0 at the top.
    pub rgba: Vec<u8>,
    /// The value shown as the top of the scale (99th percentile).
    pub scale_max: f32,
    /// The largest value in the frame.
    pub max: f32,
    /// Mean over the pixels.
    pub mean: f32,
}

/// Map the float output (RGBA f32 per pixel) to heat colours.
pub fn heat_map(floats: &[f32], metric: CostMetric) -> HeatMap {
    let channel = match metric {
        CostMetric::Nodes => 0,
        CostMetric::Triangles => 1,
    };
    let values: Vec<f32> = floats.chunks_exact(4).map(|px| px[channel].max(0.0)).collect();
    let max = values.iter().copied().fold(0.0, f32::max);
    let mean = if values.is_empty() { 0.0 } else { values.iter().map(|&v| v as f64).sum::<f64>() as f32 / values.len() as f32 };
    let mut sorted = values.clone();
    let scale_max = if sorted.is_empty() {
        0.0
    } else {
        let k = ((sorted.len() - 1) as f64 * 0.99).ceil() as usize;
        *sorted.select_nth_unstable_by(k, f32::total_cmp).1
    };
    let scale = if scale_max > 0.0 { 1.0 / scale_max } else { 0.0 };
    let mut rgba = Vec::with_capacity(values.len() * 4);
    for v in values {
        let [r, g, b] = heat_color(v * scale);
        rgba.extend_from_slice(&[r, g, b, 255]);
    }
    HeatMap { rgba, scale_max, max, mean }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scale_ends_and_is_monotonic_in_brightness() {
        assert_eq!(heat_color(0.0), [0, 0, 4]);
        assert_eq!(heat_color(1.0), [252, 255, 164]);
        assert_eq!(heat_color(7.0), [252, 255, 164]);
        assert_eq!(heat_color(f32::NAN), [0, 0, 4]);
        let lum = |c: [u8; 3]| c[0] as u32 + c[1] as u32 + c[2] as u32;
        let mut last = 0;
        for i in 0..=20 {
            let l = lum(heat_color(i as f32 / 20.0));
            assert!(l >= last, "brightness drops at {i}");
            last = l;
        }
    }

    #[test]
    fn heat_map_uses_the_chosen_counter() {
        let floats = [0.0, 10.0, 0.0, 1.0, 100.0, 0.0, 0.0, 1.0];
        let nodes = heat_map(&floats, CostMetric::Nodes);
        assert_eq!(nodes.max, 100.0);
        assert_eq!(&nodes.rgba[4..8], &[252, 255, 164, 255]);
        assert_eq!(&nodes.rgba[0..4], &[0, 0, 4, 255]);
        let tris = heat_map(&floats, CostMetric::Triangles);
        assert_eq!(tris.max, 10.0);
        assert_eq!(tris.mean, 5.0);
    }
}

//! The cost view: the `Aov::Cost` float output (x = BVH nodes visited, y = triangles
//! tested, summed over the pixel's rays) as a heat map, with the library's colour scale
//! (`tracer::heat_map`, shared with `render --aov cost -o cost.png`).

use crate::app::state::CostMetric;
pub(crate) use crate::tracer::heat_map::HeatMap;

/// Map the float output (RGBA f32 per pixel) to heat colours for `metric`.
pub(crate) fn heat_map(floats: &[f32], metric: CostMetric) -> HeatMap {
    let channel = match metric {
        CostMetric::Nodes => 0,
        CostMetric::Triangles => 1,
    };
    let values: Vec<f32> = floats.chunks_exact(4).map(|px| px[channel]).collect();
    crate::tracer::heat_map::heat_map(&values)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn picks_the_metric_channel() {
        // Two pixels: (nodes, triangles) = (1, 100) and (2, 50).
        let floats = [1.0, 100.0, 0.0, 1.0, 2.0, 50.0, 0.0, 1.0];
        assert_eq!(heat_map(&floats, CostMetric::Nodes).max, 2.0);
        assert_eq!(heat_map(&floats, CostMetric::Triangles).max, 100.0);
    }
}

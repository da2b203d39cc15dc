//! Axis helpers for the log-log charts: tick positions (decades, with 2 and 5 between
//! them on short ranges), ranges padded and snapped to 1-2-5 steps, and the tick labels
//! (100, 1k, 4M; 512² for square pixel counts).

/// A number in at most 3 significant digits, without trailing zeros: 0.05, 1, 250, 5000.
pub(super) fn short_number(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let digits = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// 100, 1k, 10k, 1M, 10M.
pub(super) fn count_label(v: f64) -> String {
    let (d, suffix) = if v >= 1e9 {
        (1e9, "G")
    } else if v >= 1e6 {
        (1e6, "M")
    } else if v >= 1e3 {
        (1e3, "k")
    } else {
        (1.0, "")
    };
    format!("{}{suffix}", short_number(v / d))
}

/// 512² for a square pixel count, else the count.
pub(super) fn pixels_label(v: f64) -> String {
    let side = v.sqrt().round();
    if (side * side - v).abs() < 0.5 {
        format!("{side}²")
    } else {
        count_label(v)
    }
}

/// Bold ticks (decades, with 2 and 5 between them on a short range) and light grid lines
/// (every integer multiple of each decade) inside `lo..hi`.
pub(super) fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let first = lo.log10().floor() as i32;
    let last = hi.log10().ceil() as i32;
    let short = last - first <= 3;
    let mut bold = Vec::new();
    let mut light = Vec::new();
    for e in first..=last {
        let decade = 10f64.powi(e);
        for m in 1..10 {
            let v = decade * m as f64;
            if v < lo || v > hi {
                continue;
            }
            if m == 1 || (short && (m == 2 || m == 5)) {
                bold.push(v);
            } else {
                light.push(v);
            }
        }
    }
    (bold, light)
}

/// The nearest of 1, 2, 5 times a power of ten below `v` (above with `up`).
pub(super) fn snap_125(v: f64, up: bool) -> f64 {
    let decade = 10f64.powf(v.log10().floor());
    let candidates = [1.0, 2.0, 5.0, 10.0].map(|m| m * decade);
    if up {
        candidates.into_iter().find(|c| *c >= v * (1.0 - 1e-9)).unwrap_or(10.0 * decade)
    } else {
        candidates.into_iter().rev().find(|c| *c <= v * (1.0 + 1e-9)).unwrap_or(decade)
    }
}

/// Range of the values, widened by `pad` on each side (factor, for log axes).
pub(super) fn log_range(values: impl Iterator<Item = f64>, pad: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && *v > 0.0) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.1, 10.0);
    }
    if hi / lo < 4.0 {
        let mid = (hi * lo).sqrt();
        lo = lo.min(mid / 2.0);
        hi = hi.max(mid * 2.0);
    }
    (lo / pad, hi * pad)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels() {
        assert_eq!(count_label(100.0), "100");
        assert_eq!(count_label(1000.0), "1k");
        assert_eq!(count_label(4_000_000.0), "4M");
        assert_eq!(short_number(0.05), "0.05");
        assert_eq!(short_number(0.2), "0.2");
        assert_eq!(short_number(5000.0), "5000");
        assert_eq!(short_number(33.3333), "33.3");
        assert_eq!(pixels_label(512.0 * 512.0), "512²");
        let (bold, light) = log_ticks(0.15, 40.0);
        assert_eq!(bold, vec![0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0]);
        assert!(light.contains(&3.0) && !light.contains(&2.0));
    }
}

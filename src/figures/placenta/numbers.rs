//! Numbers for scales and labels: rounding up to two digits, round lengths,
//! percentiles and values written with their sign.

use unfold_render::format_value;

/// `x > 0` rounded up to two significant digits (0.497 -> 0.5, 0.0441 ->
/// 0.045), for readable scale ends.
pub(super) fn ceil_2(x: f64) -> f64 {
    if !(x.is_finite() && x > 0.0) {
        return x;
    }
    let p = 10f64.powf(x.log10().floor() - 1.0);
    let r = (x / p).ceil() * p;
    // Undo representation noise (0.5 shown as 0.5, not 0.5000000001).
    format!("{r:.12e}").parse().unwrap_or(r)
}

/// A round length (1, 2 or 5 times a power of ten) of at most `max`.
pub(super) fn nice_length(max: f64) -> f64 {
    if !(max.is_finite() && max > 0.0) {
        return 1.0;
    }
    let p = 10f64.powf(max.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|k| k * p)
        .find(|&l| l <= max)
        .unwrap_or(p)
}

/// Nearest-rank percentile `q` in [0, 1] of sorted values.
pub(super) fn percentile(sorted: &[f64], q: f64) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    let k = (q * (sorted.len() - 1) as f64).round() as usize;
    sorted.get(k.min(sorted.len() - 1)).copied()
}

/// A value with its sign (`+9.67`, `-9.67`, `0`).
pub(super) fn signed(v: f64) -> String {
    if v > 0.0 {
        format!("+{}", format_value(v))
    } else {
        format_value(v)
    }
}

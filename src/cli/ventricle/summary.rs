//! The one-line summary of a ventricle run on stdout (also the demo's).

use crate::organs::ventricle::Report;

/// A length in micrometres: three decimals, or three significant digits
/// below 0.01 um.
fn micrometres(x: f64) -> String {
    if x == 0.0 || x.abs() >= 0.01 {
        format!("{x:.3}")
    } else {
        format!("{x:.2e}")
    }
}

/// A one-line summary of a report: round trip, AHA segments, timings.
pub(crate) fn summary(r: &Report) -> String {
    let aha = match &r.aha_points {
        Some(counts) => format!(
            "{}/17 AHA segments non-empty",
            counts.iter().filter(|&&c| c > 0).count()
        ),
        None => "no AHA segments (RV)".into(),
    };
    let s = &r.seconds;
    format!(
        "{} points, round trip mean {} um, max {} um; {aha}; {} flipped disk triangles; \
         {:.2} s (disk {:.2}, Laplace {:.2}, streamlines {:.2}, inverse {:.2})",
        r.anatomy_points,
        micrometres(r.roundtrip_error_um.mean),
        micrometres(r.roundtrip_error_um.max),
        r.flipped_disk_triangles,
        // the disk map and the field run at the same time
        s.disk.max(s.laplace) + s.streamlines + s.inverse,
        s.disk,
        s.laplace,
        s.streamlines,
        s.inverse
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn micrometres_keep_three_significant_digits_when_small() {
        assert_eq!(micrometres(1.23456), "1.235");
        assert_eq!(micrometres(0.0), "0.000");
        assert_eq!(micrometres(0.000148), "1.48e-4");
    }
}

//! AHA 17-segment labels from LV disk positions (ALGORITHMS 3.6).

/// The AHA segment (1..=17) of an LV disk position `uv` as displayed (the
/// pipeline labels the disk after its display warp `r' = r^n`, so that
/// labels and bull's-eye agree), with `r = |uv|` and `a` its angle from +x (the septum),
/// counter-clockwise with the anterior landmark on +y, in degrees `[0, 360)`:
///
/// ```text
/// r < 1/4            17 apex
/// 1/4 <= r < 1/2     apical: 13 anterior [45,135), 14 septal [315,45),
///                    15 inferior [225,315), 16 lateral [135,225)
/// 1/2 <= r < 3/4     mid:    6 + basal segment
/// 3/4 <= r           basal:  1 anterior [60,120), 2 anteroseptal [0,60),
///                    3 inferoseptal [300,360), 4 inferior [240,300),
///                    5 inferolateral [180,240), 6 anterolateral [120,180)
/// ```
///
/// 0 for a non-finite position.
pub fn aha_segment(uv: [f64; 2]) -> u8 {
    if !(uv[0].is_finite() && uv[1].is_finite()) {
        return 0;
    }
    let r = uv[0].hypot(uv[1]);
    if r < 0.25 {
        return 17;
    }
    let a = uv[1].atan2(uv[0]).to_degrees().rem_euclid(360.0);
    if r < 0.5 {
        return match a {
            a if (45.0..135.0).contains(&a) => 13,
            a if (135.0..225.0).contains(&a) => 16,
            a if (225.0..315.0).contains(&a) => 15,
            _ => 14,
        };
    }
    // Basal segments by 60-degree sector from +x: [0,60) 2, [60,120) 1,
    // [120,180) 6, [180,240) 5, [240,300) 4, [300,360) 3.
    const BASAL: [u8; 6] = [2, 1, 6, 5, 4, 3];
    let basal = BASAL[((a / 60.0) as usize).min(5)];
    if r < 0.75 { basal + 6 } else { basal }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(r: f64, deg: f64) -> [f64; 2] {
        let t = deg.to_radians();
        [r * t.cos(), r * t.sin()]
    }

    #[test]
    fn every_segment_sits_where_the_aha_puts_it() {
        let cases = [
            (0.1, 0.0, 17),
            (0.3, 90.0, 13),
            (0.3, 0.0, 14),
            (0.3, 350.0, 14),
            (0.3, 270.0, 15),
            (0.3, 180.0, 16),
            (0.6, 90.0, 7),
            (0.6, 30.0, 8),
            (0.6, 330.0, 9),
            (0.6, 270.0, 10),
            (0.6, 210.0, 11),
            (0.6, 150.0, 12),
            (0.9, 90.0, 1),
            (0.9, 30.0, 2),
            (0.9, 330.0, 3),
            (0.9, 270.0, 4),
            (0.9, 210.0, 5),
            (0.9, 150.0, 6),
            (1.0, 150.0, 6),
        ];
        for (r, deg, seg) in cases {
            assert_eq!(aha_segment(at(r, deg)), seg, "r {r}, {deg} deg");
        }
        // Boundaries belong to the outer ring / the counter-clockwise sector.
        assert_eq!(aha_segment(at(0.25, 90.0)), 13);
        assert_eq!(aha_segment(at(0.5, 90.0)), 7);
        assert_eq!(aha_segment(at(0.75, 90.0)), 1);
        assert_eq!(aha_segment(at(0.9, 60.0 + 1e-9)), 1);
        assert_eq!(aha_segment([f64::NAN, 0.0]), 0);
    }

    #[test]
    fn a_fine_sampling_of_the_disk_finds_all_17_segments_with_their_areas() {
        // Areas: 16 % of the disk is the apex cap (r < 1/4: 1/16), each ring
        // splits evenly among its segments.
        let n = 400;
        let mut count = [0usize; 18];
        for i in 0..n {
            for j in 0..n {
                let p = [
                    2.0 * (i as f64 + 0.5) / n as f64 - 1.0,
                    2.0 * (j as f64 + 0.5) / n as f64 - 1.0,
                ];
                if p[0].hypot(p[1]) < 1.0 {
                    count[aha_segment(p) as usize] += 1;
                }
            }
        }
        assert_eq!(count[0], 0);
        let total: usize = count.iter().sum();
        let frac = |s: usize| count[s] as f64 / total as f64;
        assert!((frac(17) - 1.0 / 16.0).abs() < 0.005);
        for s in 13..=16 {
            assert!((frac(s) - 3.0 / 16.0 / 4.0).abs() < 0.005, "segment {s}");
        }
        for s in 7..=12 {
            assert!((frac(s) - 5.0 / 16.0 / 6.0).abs() < 0.005, "segment {s}");
        }
        for s in 1..=6 {
            assert!((frac(s) - 7.0 / 16.0 / 6.0).abs() < 0.005, "segment {s}");
        }
    }
}

//! The source paper's check of the LV map on a cup (ALGORITHMS 3.7): rings
//! of anatomy points at constant height map to circles of the disk, and
//! meridians (points of one azimuth) to rays from its centre.

use super::CylinderPoint;

/// How far mapped rings are from circles and meridians from rays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RingsMeridians {
    /// The largest relative radius spread of a ring,
    /// `max_i |r_i - mean r| / mean r` with `r_i = |(xi_i, zeta_i)|`.
    pub worst_radius_spread: f64,
    /// The largest angle of a meridian's point from its meridian's
    /// circular mean angle, degrees (`atan2(zeta, xi)`).
    pub worst_angle_deg: f64,
}

/// The spreads of the mapped `rings` and `meridians` (lists of indices into
/// `coords`); rings or meridians without points are skipped. Indices out of
/// range are skipped too: the result only measures what it can see.
pub fn rings_and_meridians(
    coords: &[CylinderPoint],
    rings: &[Vec<usize>],
    meridians: &[Vec<usize>],
) -> RingsMeridians {
    let mut worst_ring: f64 = 0.0;
    for ring in rings {
        let r: Vec<f64> = ring
            .iter()
            .filter_map(|&i| coords.get(i))
            .map(|c| c.xi.hypot(c.zeta))
            .collect();
        if r.is_empty() {
            continue;
        }
        let mean = r.iter().sum::<f64>() / r.len() as f64;
        if mean > 0.0 {
            let spread = r.iter().map(|x| (x - mean).abs()).fold(0.0, f64::max) / mean;
            worst_ring = worst_ring.max(spread);
        }
    }
    let mut worst_ray: f64 = 0.0;
    for m in meridians {
        let a: Vec<f64> = m
            .iter()
            .filter_map(|&i| coords.get(i))
            .map(|c| c.zeta.atan2(c.xi))
            .collect();
        let (s, c) = a
            .iter()
            .fold((0.0, 0.0), |(s, c), x| (s + x.sin(), c + x.cos()));
        let mean = s.atan2(c);
        for x in &a {
            let d = (x - mean).sin().atan2((x - mean).cos()).abs().to_degrees();
            worst_ray = worst_ray.max(d);
        }
    }
    RingsMeridians {
        worst_radius_spread: worst_ring,
        worst_angle_deg: worst_ray,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn at(r: f64, a: f64) -> CylinderPoint {
        CylinderPoint {
            xi: r * a.cos(),
            zeta: r * a.sin(),
            depth: 0.5,
        }
    }

    proptest! {
        /// Exact circles and rays measure zero whatever their radii and
        /// angles; moving one point off measures exactly its offset.
        #[test]
        fn circles_and_rays_measure_zero(
            radii in prop::collection::vec(0.05..1.0f64, 1..5),
            angles in prop::collection::vec(-3.1..3.1f64, 1..6),
            bump in 0.0..0.2f64,
        ) {
            let mut coords = Vec::new();
            let mut rings = Vec::new();
            for &r in &radii {
                let ring: Vec<usize> = angles.iter().map(|&a| {
                    coords.push(at(r, a));
                    coords.len() - 1
                }).collect();
                rings.push(ring);
            }
            let meridians: Vec<Vec<usize>> = (0..angles.len())
                .map(|k| rings.iter().map(|ring| ring[k]).collect())
                .collect();
            let m = rings_and_meridians(&coords, &rings, &meridians);
            prop_assert!(m.worst_radius_spread < 1e-12);
            prop_assert!(m.worst_angle_deg < 1e-9);
            // A ring of two points, one at radius r (1 + bump).
            let two = [at(0.5, 0.3), at(0.5 * (1.0 + bump), 0.3 + 2.0)];
            let m = rings_and_meridians(&two, &[vec![0, 1]], &[]);
            let want = (bump / 2.0) / (1.0 + bump / 2.0);
            prop_assert!((m.worst_radius_spread - want).abs() < 1e-12);
        }
    }
}

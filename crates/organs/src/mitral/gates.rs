//! The valve's quality gates (`report.json`'s `gates`): measured values a
//! wrong result cannot have, checked after the maps are made.
//!
//! - `annulus.leaflet_area_ratio`: both leaflets' 3D area over the area of
//!   the disk of the annulus' perimeter `L`, `(A_a + A_p) / (L^2 / 4 pi)`,
//!   in [[`LEAFLET_AREA_RATIO`]]. The leaflets close the orifice, whose
//!   area is at most `L^2 / 4 pi` (the isoperimetric inequality) and, for
//!   a D-shaped annulus (ellipticity 0.6-0.9), over half of it; they
//!   overlap in the coaptation zone and billow, so a real pair has about
//!   1-2.5 times that disk. Below the range the surfaces do not span the
//!   ring (a leaflet cropped to a fragment, the wrong label); above it they
//!   are not this ring's leaflets (a chamber wall, a ring in other units).
//! - `leaflets.area_ratio`: anterior over posterior area, in
//!   [[`LEAFLET_RATIO`]]: real leaflets have similar areas (about 1-1.6:
//!   the anterior taller, the posterior longer); a ratio outside the range
//!   is one leaflet given twice, a swapped or partial label.
//! - `map.flipped_triangles`: 0. The flip-free relaxation (`sd`) never
//!   flips, so a flip there is a fault (the run stops); the spring baseline
//!   may, and its map is kept with the flips counted (the fallback).
//!
//! Every test valve and the demo's lie well inside these ranges (the
//! generator's default valve: 1.48 and 1.38).

use super::{RelaxMode, Report};
use crate::gate::Gates;
use crate::{OrganError, Requirement};
use std::f64::consts::PI;

/// The range of `annulus.leaflet_area_ratio`.
pub const LEAFLET_AREA_RATIO: (f64, f64) = (0.3, 8.0);
/// The range of `leaflets.area_ratio` (anterior / posterior).
pub const LEAFLET_RATIO: (f64, f64) = (0.2, 5.0);

/// The gates of a finished run (see the module docs).
///
/// # Errors
/// [`OrganError::Gate`] for a failed gate without a fallback.
pub fn check(report: &Report, relax: RelaxMode) -> Result<Gates, OrganError> {
    let mut gates = Gates::new();
    let a = &report.leaflet_area_mm2;
    let l = report.annulus_length_mm;
    let disk = l * l / (4.0 * PI);
    let (lo, hi) = LEAFLET_AREA_RATIO;
    gates.check(
        "annulus.leaflet_area_ratio",
        (a.anterior + a.posterior) / disk,
        Requirement::Within(lo, hi),
        "the leaflets do not span this annulus: give the leaflet surfaces of this valve \
         (--anterior/--posterior) and its ring (--annulus) in the same units",
    )?;
    let (lo, hi) = LEAFLET_RATIO;
    gates.check(
        "leaflets.area_ratio",
        a.anterior / a.posterior,
        Requirement::Within(lo, hi),
        "one leaflet is far larger than the other: check that --anterior and --posterior are \
         the two leaflets, each whole",
    )?;
    let flipped = report.flipped_triangles as f64;
    match relax {
        RelaxMode::Sd => gates.check(
            "map.flipped_triangles",
            flipped,
            Requirement::CountWithin(0, 0),
            "the flip-free relaxation flipped triangles: please report it with the leaflets",
        )?,
        RelaxMode::Spring => {
            gates.fallback(
                "map.flipped_triangles",
                flipped,
                Requirement::CountWithin(0, 0),
                "the spring map is kept with its flips counted; --relax sd gives a flip-free map",
            );
        }
    }
    Ok(gates)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mitral::{Pipeline, ValveInput};
    use unfold_mesh::shapes::{ValveParams, mitral_valve};

    fn report() -> Report {
        let v = mitral_valve(&ValveParams::default()).unwrap();
        let input = ValveInput {
            anterior: &v.anterior,
            posterior: &v.posterior,
            annulus: &v.annulus,
        };
        Pipeline::new().run(&input).unwrap().report
    }

    #[test]
    fn the_generated_valve_passes_every_gate_with_margin() {
        let r = report();
        let names: Vec<&str> = r.gates.0.iter().map(|g| g.name.as_ref()).collect();
        assert_eq!(
            names,
            [
                "annulus.leaflet_area_ratio",
                "leaflets.area_ratio",
                "map.flipped_triangles"
            ]
        );
        assert!(r.gates.all_passed(), "{:?}", r.gates);
        let v = |n: &str| r.gates.get(n).unwrap().value;
        eprintln!(
            "area ratio {} leaflets {}",
            v("annulus.leaflet_area_ratio"),
            v("leaflets.area_ratio")
        );
        assert!((0.9..2.5).contains(&v("annulus.leaflet_area_ratio")));
        assert!((0.7..1.6).contains(&v("leaflets.area_ratio")));
        assert_eq!(v("map.flipped_triangles"), 0.0);
    }

    #[test]
    fn leaflets_that_do_not_span_the_ring_fail_naming_the_fix() {
        let mut r = report();
        r.leaflet_area_mm2.anterior *= 20.0;
        r.leaflet_area_mm2.posterior *= 20.0;
        let e = check(&r, RelaxMode::Sd).unwrap_err().to_string();
        assert!(
            e.starts_with("quality gate annulus.leaflet_area_ratio: "),
            "{e}"
        );
        assert!(
            e.contains("--anterior/--posterior") && !e.contains('\n'),
            "{e}"
        );
        let mut r = report();
        r.leaflet_area_mm2.posterior /= 10.0;
        let e = check(&r, RelaxMode::Sd).unwrap_err().to_string();
        assert!(e.starts_with("quality gate leaflets.area_ratio: "), "{e}");
    }

    #[test]
    fn flips_stop_sd_and_are_the_spring_fallback() {
        let mut r = report();
        r.flipped_triangles = 3;
        let e = check(&r, RelaxMode::Sd).unwrap_err().to_string();
        assert!(
            e.starts_with("quality gate map.flipped_triangles: 3 "),
            "{e}"
        );
        let g = check(&r, RelaxMode::Spring).unwrap();
        let f = g.get("map.flipped_triangles").unwrap();
        assert!(!f.passed && f.fallback.as_deref().unwrap().contains("--relax sd"));
    }
}

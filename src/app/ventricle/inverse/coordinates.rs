//! Where the cylinder coordinates of a mesh's points come from
//! ([`Coordinates`]), and reading them: the point arrays `xi`, `zeta`,
//! `depth`, or the points as `(X, Y, depth)` on the displayed disk (the
//! display warp inverted).

use crate::app::error::{AppError, about};
use crate::mesh::CellMesh;
use crate::organs::ventricle::disk::display_warp;
use crate::organs::ventricle::{Chamber, CylinderPoint};
use serde::{Deserialize, Serialize};

/// `--coordinates`: where the cylinder coordinates of the mesh's points
/// come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Coordinates {
    /// The point arrays when all three are present, else the points.
    #[default]
    Auto,
    /// The point arrays `xi`, `zeta`, `depth` (harmonic disk and depth).
    Arrays,
    /// The points as `(X, Y, depth)`, `(X, Y)` on the displayed disk.
    Points,
}

crate::param::named!(Coordinates { Auto => "auto", Arrays => "arrays", Points => "points" });

/// Where the coordinates came from, for the report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Source {
    /// The point arrays `xi`, `zeta`, `depth`.
    Arrays,
    /// The points as `(X, Y, depth)`.
    Points,
}

/// The point arrays of the cylinder coordinates.
pub const ARRAYS: [&str; 3] = ["xi", "zeta", "depth"];

/// The cylinder coordinates of `mesh`'s points (read as `how` says; for
/// the points, the display warp of `chamber` with `display_exponent`
/// inverted, [`harmonic_positions`]), and where they came from.
///
/// # Errors
/// A usage error naming `path` for one or two of the arrays alone (with
/// `auto`), an array missing (with `arrays`) or not one value per point.
pub fn cylinder_coordinates(
    mesh: &CellMesh,
    path: &str,
    how: Coordinates,
    chamber: Chamber,
    display_exponent: f64,
) -> Result<(Vec<CylinderPoint>, Source), AppError> {
    let present: Vec<&str> = ARRAYS
        .iter()
        .copied()
        .filter(|n| mesh.point_data.get(n).is_some())
        .collect();
    let source = match how {
        Coordinates::Points => Source::Points,
        Coordinates::Arrays => {
            if present.len() < 3 {
                let missing: Vec<&str> = ARRAYS
                    .iter()
                    .copied()
                    .filter(|n| !present.contains(n))
                    .collect();
                return Err(about(
                    path,
                    format!(
                        "has no point array {} (--coordinates arrays reads xi, zeta and depth)",
                        missing.join(", ")
                    ),
                ));
            }
            Source::Arrays
        }
        Coordinates::Auto => match present.len() {
            3 => Source::Arrays,
            0 => Source::Points,
            _ => {
                return Err(about(
                    path,
                    format!(
                        "has the point array(s) {} but not all of xi, zeta, depth: give all \
                         three, or --coordinates points to read (X, Y, depth) from the points",
                        present.join(", ")
                    ),
                ));
            }
        },
    };
    let n = mesh.positions.len();
    let coords = match source {
        Source::Arrays => {
            let mut cols = Vec::with_capacity(3);
            for name in ARRAYS {
                let f = mesh
                    .point_data
                    .get(name)
                    .ok_or_else(|| about(path, format!("has no point array {name}")))?;
                if f.components() != 1 || f.tuples() != n {
                    return Err(about(
                        path,
                        format!(
                            "point array {name} has {} component(s) and {} tuple(s); one value \
                             per point ({n}) is needed",
                            f.components(),
                            f.tuples()
                        ),
                    ));
                }
                cols.push(f.values().to_f64());
            }
            (0..n)
                .map(|i| CylinderPoint {
                    xi: cols[0][i],
                    zeta: cols[1][i],
                    depth: cols[2][i],
                })
                .collect()
        }
        Source::Points => {
            let shown: Vec<[f64; 2]> = mesh.positions.iter().map(|p| [p.x, p.y]).collect();
            let uv = harmonic_positions(chamber, &shown, display_exponent)?;
            uv.iter()
                .zip(&mesh.positions)
                .map(|(q, p)| CylinderPoint {
                    xi: q[0],
                    zeta: q[1],
                    depth: p.z,
                })
                .collect()
        }
    };
    Ok((coords, source))
}

/// The harmonic disk positions of displayed ones: the LV's display warp
/// `r' = r^n` inverted, `r = r'^(1/n)` (the warp with exponent `1/n`); the
/// RV's half disk is not warped. Non-finite positions stay non-finite.
///
/// # Errors
/// A usage error for an exponent that is not finite and > 0.
pub fn harmonic_positions(
    chamber: Chamber,
    shown: &[[f64; 2]],
    exponent: f64,
) -> Result<Vec<[f64; 2]>, AppError> {
    match chamber {
        Chamber::Lv => {
            display_warp(shown, 1.0 / exponent).map_err(|e| AppError::Usage(e.to_string()))
        }
        Chamber::Rv => Ok(shown.to_vec()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Field;
    use crate::mesh::nalgebra::Point3;
    use crate::organs::ventricle::pipeline::displayed;
    use proptest::prelude::*;

    proptest! {
        /// The display warp inverted: `harmonic_positions(displayed(uv))
        /// = uv` on the LV disk for any exponent, and the RV untouched.
        #[test]
        fn the_display_warp_is_inverted(
            r in 0.0..1.0f64,
            a in 0.0..std::f64::consts::TAU,
            n in 0.1..3.0f64,
        ) {
            let uv = [[r * a.cos(), r * a.sin()]];
            let shown = displayed(Chamber::Lv, &uv, n).unwrap();
            let back = harmonic_positions(Chamber::Lv, &shown, n).unwrap();
            prop_assert!((back[0][0] - uv[0][0]).abs() < 1e-12);
            prop_assert!((back[0][1] - uv[0][1]).abs() < 1e-12);
            let rv = harmonic_positions(Chamber::Rv, &uv, n).unwrap();
            prop_assert_eq!(rv, uv.to_vec());
        }
    }

    #[test]
    fn names_are_the_flag_s() {
        crate::param::named::check_named::<Coordinates>();
    }

    #[test]
    fn partial_arrays_are_refused_and_points_are_read_as_displayed() {
        let mut m = CellMesh::from_points(vec![Point3::new(0.5, 0.0, 0.25)]);
        let p = "n.vtu";
        let (c, s) = cylinder_coordinates(&m, p, Coordinates::Auto, Chamber::Lv, 0.5).unwrap();
        assert_eq!(s, Source::Points);
        assert!((c[0].xi - 0.25).abs() < 1e-15 && c[0].zeta == 0.0 && c[0].depth == 0.25);
        m.point_data.insert(Field::scalars("xi", vec![0.1]));
        let e = cylinder_coordinates(&m, p, Coordinates::Auto, Chamber::Lv, 0.5).unwrap_err();
        assert!(e.to_string().contains("not all of xi, zeta, depth"), "{e}");
        let e = cylinder_coordinates(&m, p, Coordinates::Arrays, Chamber::Lv, 0.5).unwrap_err();
        assert!(e.to_string().contains("no point array zeta, depth"), "{e}");
        let (c, s) = cylinder_coordinates(&m, p, Coordinates::Points, Chamber::Rv, 0.5).unwrap();
        assert_eq!(s, Source::Points);
        assert_eq!((c[0].xi, c[0].depth), (0.5, 0.25));
    }
}

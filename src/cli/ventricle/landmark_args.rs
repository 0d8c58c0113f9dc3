//! The landmark flags of a heart, shared by `unfold ventricle` and `unfold
//! ventricle-inverse`: the rim landmarks (or the RV insertion points they
//! are derived from, or a markups file), the apex and the rim's name; and
//! the parser of a point `X,Y,Z`.

use crate::app::ventricle::HeartLandmarks;
use crate::mesh::nalgebra::Point3;
use clap::Args;
use std::path::PathBuf;

/// Parses a point `X,Y,Z` (spaces around the commas allowed).
pub(crate) fn parse_point(s: &str) -> Result<Point3<f64>, String> {
    let fields: Vec<&str> = s.split(',').map(str::trim).collect();
    let bad = || format!("expected X,Y,Z (three numbers separated by commas), got {s:?}");
    if fields.len() != 3 {
        return Err(bad());
    }
    let mut x = [0.0; 3];
    for (k, f) in fields.iter().enumerate() {
        let v: f64 = f.parse().map_err(|_| bad())?;
        if !v.is_finite() {
            return Err(format!("coordinate {f:?} of {s:?} is not finite"));
        }
        x[k] = v;
    }
    Ok(Point3::new(x[0], x[1], x[2]))
}

/// `--anterior`, `--inferior`, `--rv-landmarks`, `--apex`, `--landmarks`,
/// `--rim-near` ([`HeartLandmarks::on_surface`] turns them into landmarks
/// on S).
#[derive(Debug, Clone, Args)]
pub(crate) struct HeartLandmarkArgs {
    /// Anterior RV insertion point (LV) or first septal corner (RV), on the
    /// rim of S.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_hyphen_values = true)]
    pub(crate) anterior: Option<Point3<f64>>,
    /// Inferior RV insertion point (LV) or second septal corner (RV), on the
    /// rim of S.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_hyphen_values = true)]
    pub(crate) inferior: Option<Point3<f64>>,
    /// LV: the anterior and inferior RV insertion points where the user
    /// marked them (at the base of the RV ridges, outside S): the rim
    /// landmarks are derived from them, as the source paper does (rays from
    /// the rim's centroid through them meet S; the nearest rim vertices).
    /// Instead of --anterior/--inferior.
    #[arg(long, value_name = "X,Y,Z", num_args = 2, value_parser = parse_point,
          allow_hyphen_values = true, conflicts_with_all = ["anterior", "inferior", "landmarks"])]
    pub(crate) rv_landmarks: Vec<Point3<f64>>,
    /// The apex (snapped to the nearest vertex of S) [default: the vertex of
    /// S farthest from the rim's centroid].
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_hyphen_values = true)]
    pub(crate) apex: Option<Point3<f64>>,
    /// The landmarks from a 3D Slicer markups file (.mrk.json, or .fcsv):
    /// points labelled anterior, inferior and (optional) apex, any case; LPS
    /// points are converted to RAS. Instead of --anterior/--inferior/--apex.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["anterior", "inferior", "apex"])]
    pub(crate) landmarks: Option<PathBuf>,
    /// A point on the basal rim or at the centre of its opening, naming it
    /// when S has several openings [default: the opening the rim landmarks
    /// lie on, which must be the largest facing away from the apex when
    /// --apex is given; without rim landmarks, that opening]; the other
    /// openings are capped.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_hyphen_values = true)]
    pub(crate) rim_near: Option<Point3<f64>>,
}

impl HeartLandmarkArgs {
    /// The landmarks as given.
    pub(crate) fn landmarks(&self) -> HeartLandmarks {
        HeartLandmarks {
            anterior: self.anterior,
            inferior: self.inferior,
            rv_landmarks: self.rv_landmarks.clone(),
            apex: self.apex,
            landmarks: self.landmarks.clone(),
            rim_near: self.rim_near,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_parse_with_or_without_spaces() {
        assert_eq!(
            parse_point("1,2.5,-3").unwrap(),
            Point3::new(1.0, 2.5, -3.0)
        );
        assert_eq!(
            parse_point(" 1, 2 ,3e1 ").unwrap(),
            Point3::new(1.0, 2.0, 30.0)
        );
        for bad in ["1,2", "1,2,3,4", "1,,3", "a,b,c", "", "1 2 3"] {
            let e = parse_point(bad).unwrap_err();
            assert!(e.contains("expected X,Y,Z"), "{bad}: {e}");
        }
        assert!(parse_point("1,nan,3").unwrap_err().contains("not finite"));
        assert!(parse_point("inf,0,3").unwrap_err().contains("not finite"));
    }
}

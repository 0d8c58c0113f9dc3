//! The landmark flags of a heart, shared by `unfold ventricle` and `unfold
//! ventricle-inverse`: the rim landmarks (or the RV insertion points they
//! are derived from, or a markups file), the apex and the rim's name.

use super::ventricle::parse_point;
use crate::mesh::nalgebra::Point3;
use clap::Args;
use std::path::PathBuf;

/// `--anterior`, `--inferior`, `--rv-landmarks`, `--apex`, `--landmarks`,
/// `--rim-near` ([`super::ventricle::heart_landmarks`] turns them into
/// landmarks on S).
#[derive(Debug, Clone, Args)]
pub(crate) struct HeartLandmarkArgs {
    /// Anterior RV insertion point (LV) or first septal corner (RV), on the
    /// rim of S.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_hyphen_values = true,
          required_unless_present_any = ["landmarks", "rv_landmarks"])]
    pub(crate) anterior: Option<Point3<f64>>,
    /// Inferior RV insertion point (LV) or second septal corner (RV), on the
    /// rim of S.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_hyphen_values = true,
          required_unless_present_any = ["landmarks", "rv_landmarks"])]
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
    /// A point on or near the basal rim, naming it when S has several
    /// openings [default: the opening nearest the rim landmarks]; the other
    /// openings are capped.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_hyphen_values = true)]
    pub(crate) rim_near: Option<Point3<f64>>,
}

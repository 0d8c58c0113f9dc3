//! A heart's landmarks as given: the rim landmarks (anterior, inferior)
//! and apex as points, or from a 3D Slicer markups file (points labelled
//! `anterior`, `inferior`, `apex`), or (LV) the rim landmarks derived from
//! the two RV insertion points (`--rv-landmarks`); and a point naming the
//! basal rim among several openings of S.

use crate::app::error::{AppError, organ};
use crate::io::{FilePath, IoError, MarkupsError, read_markups};
use crate::mesh::TriMesh;
use crate::mesh::nalgebra::Point3;
use crate::organs::ventricle::rv_landmarks::{FromRv, rim_landmarks_from_rv};
use crate::organs::ventricle::{Chamber, LandmarkPoints};
use std::path::{Path, PathBuf};

/// Label of the anterior landmark (LV) or first septal corner (RV) in a
/// markups file (compared case-insensitively; no synonyms).
const ANTERIOR_LABELS: &[&str] = &["anterior"];
/// Label of the inferior landmark (LV) or second septal corner (RV).
const INFERIOR_LABELS: &[&str] = &["inferior"];
/// Label of the apex (optional in the file).
const APEX_LABELS: &[&str] = &["apex"];

/// One heart's landmarks as given (the flags `--anterior`, `--inferior`,
/// `--rv-landmarks`, `--apex`, `--landmarks`, `--rim-near`, or their
/// `--to-...` counterparts of a transfer's second heart, which has no RV
/// insertion points). A markups file excludes the points it gives.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct HeartLandmarks {
    /// Anterior RV insertion point (LV) or first septal corner (RV), on
    /// the rim of S.
    pub anterior: Option<Point3<f64>>,
    /// Inferior RV insertion point (LV) or second septal corner (RV), on
    /// the rim of S.
    pub inferior: Option<Point3<f64>>,
    /// LV: the two RV insertion points the rim landmarks are derived from
    /// (instead of `anterior` and `inferior`).
    pub rv_landmarks: Vec<Point3<f64>>,
    /// The apex (none: the vertex of S farthest from the rim's centroid).
    pub apex: Option<Point3<f64>>,
    /// A markups file with the points labelled anterior, inferior and
    /// (optional) apex.
    pub landmarks: Option<PathBuf>,
    /// A point on or near the basal rim, naming it among several openings.
    pub rim_near: Option<Point3<f64>>,
}

/// The landmarks from a markups file, or `anterior`, `inferior` and
/// `apex`; `flags` names the two rim landmarks in the message when neither
/// is given.
fn landmark_points(
    file: Option<&Path>,
    anterior: Option<Point3<f64>>,
    inferior: Option<Point3<f64>>,
    apex: Option<Point3<f64>>,
    rim_near: Option<Point3<f64>>,
    flags: &str,
) -> Result<LandmarkPoints, AppError> {
    let Some(path) = file else {
        let (Some(anterior), Some(inferior)) = (anterior, inferior) else {
            return Err(AppError::Usage(format!("give {flags}")));
        };
        return Ok(LandmarkPoints {
            anterior,
            inferior,
            apex,
            rim_near,
        });
    };
    let m = read_markups(path)?;
    let labelled = |e: MarkupsError| -> AppError {
        IoError::Markups {
            path: FilePath(path.into()),
            source: e,
        }
        .into()
    };
    Ok(LandmarkPoints {
        anterior: m.require(ANTERIOR_LABELS).map_err(labelled)?,
        inferior: m.require(INFERIOR_LABELS).map_err(labelled)?,
        apex: m.find(APEX_LABELS).map_err(labelled)?,
        rim_near,
    })
}

impl HeartLandmarks {
    /// The landmarks as given: from the markups file (read now), else the
    /// points; `flags` names every way to give the rim landmarks in the
    /// message when neither is given.
    ///
    /// # Errors
    /// [`AppError::Usage`] without rim landmarks; reading the markups file,
    /// or a label missing from it.
    pub fn points(&self, flags: &str) -> Result<LandmarkPoints, AppError> {
        landmark_points(
            self.landmarks.as_deref(),
            self.anterior,
            self.inferior,
            self.apex,
            self.rim_near,
            flags,
        )
    }

    /// The landmarks S is built from (no surface file): the two RV
    /// insertion points as the rim landmarks when given, else
    /// [`HeartLandmarks::points`].
    ///
    /// # Errors
    /// [`HeartLandmarks::points`]'s.
    pub fn for_building(&self) -> Result<LandmarkPoints, AppError> {
        match self.rv_landmarks.as_slice() {
            [p, q] => Ok(LandmarkPoints {
                anterior: *p,
                inferior: *q,
                apex: self.apex,
                rim_near: None,
            }),
            _ => self.points(
                "--anterior and --inferior (the rim landmarks), --landmarks FILE (a markups \
                 file with them) or --rv-landmarks P Q (the RV insertion points)",
            ),
        }
    }

    /// The landmarks on S (named `surface_label` in messages) of a
    /// `chamber`: with `rv_landmarks` (LV only) the rim landmarks derived
    /// from the RV insertion points on the basal rim chosen first
    /// (`rim_near`, else the largest opening facing away from the apex;
    /// `snap_mm` bounds `rim_near`'s distance), returned too for the
    /// report, else [`HeartLandmarks::points`].
    ///
    /// # Errors
    /// [`AppError::Usage`] for RV insertion points of the RV, or not two of
    /// them; the derivation's error about S; [`HeartLandmarks::points`]'s.
    pub fn on_surface(
        &self,
        surface: &TriMesh,
        surface_label: &str,
        chamber: Chamber,
        snap_mm: f64,
    ) -> Result<(LandmarkPoints, Option<FromRv>), AppError> {
        let from_rv = match self.rv_landmarks.as_slice() {
            [] => None,
            [p, q] => {
                if chamber == Chamber::Rv {
                    return Err(AppError::Usage(
                        "--rv-landmarks derives the LV's rim landmarks; give the RV's septal \
                         corners as --anterior and --inferior"
                            .into(),
                    ));
                }
                Some(
                    rim_landmarks_from_rv(
                        surface,
                        [*p, *q],
                        self.rim_near.as_ref(),
                        self.apex.as_ref(),
                        snap_mm,
                    )
                    .map_err(|e| organ(surface_label, e))?,
                )
            }
            more => {
                return Err(AppError::Usage(format!(
                    "--rv-landmarks takes two points, got {}",
                    more.len()
                )));
            }
        };
        let landmarks = match &from_rv {
            Some(f) => LandmarkPoints {
                anterior: Point3::from(f.landmarks[0]),
                inferior: Point3::from(f.landmarks[1]),
                apex: self.apex,
                rim_near: self.rim_near,
            },
            None => self.points(
                "--anterior and --inferior (the rim landmarks), --landmarks FILE (a markups \
                 file with them) or, for the LV, --rv-landmarks P Q (the RV insertion points \
                 they are derived from)",
            )?,
        };
        Ok((landmarks, from_rv))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rim_landmarks_are_needed_and_rv_points_stand_in_for_them() {
        let none = HeartLandmarks::default();
        assert_eq!(
            none.points("--to-anterior and --to-inferior or --to-landmarks FILE")
                .unwrap_err()
                .to_string(),
            "give --to-anterior and --to-inferior or --to-landmarks FILE"
        );
        let e = none
            .on_surface(&TriMesh::new(vec![], vec![]), "S", Chamber::Lv, 5.0)
            .unwrap_err()
            .to_string();
        for route in [
            "--anterior and --inferior",
            "--landmarks FILE",
            "--rv-landmarks P Q",
        ] {
            assert!(e.contains(route), "{e}");
        }
        let rv = HeartLandmarks {
            rv_landmarks: vec![Point3::new(1.0, 0.0, 0.0), Point3::new(0.0, 1.0, 0.0)],
            ..HeartLandmarks::default()
        };
        let given = rv.for_building().unwrap();
        assert_eq!(given.anterior, Point3::new(1.0, 0.0, 0.0));
        assert_eq!(given.inferior, Point3::new(0.0, 1.0, 0.0));
    }
}

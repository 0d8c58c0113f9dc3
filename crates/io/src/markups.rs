//! 3D Slicer markups: named points (landmarks) from a `.mrk.json` file
//! (Slicer's markups schema, v1.0.x) or an older `.fcsv` file.
//!
//! **`.mrk.json`.** `{"@schema": ..., "markups": [{"type": "Fiducial",
//! "coordinateSystem": "LPS" | "RAS", "coordinateUnits": "mm" | "um",
//! "controlPoints": [{"label": "anterior", "position": [x, y, z],
//! "positionStatus": "defined", ...}, ...]}, ...]}`. The control points of
//! every markup in the file are read (of any type: a point list, a curve,
//! ...). A markup without `coordinateSystem` is LPS (the schema's default;
//! Slicer >= 4.11 writes LPS); without `coordinateUnits`, mm (`um` is
//! divided by 1000; the DICOM code form `["mm", "UCUM", "millimeter"]` is
//! read by its first entry). Control points whose `positionStatus` is not
//! `defined` (`undefined`: not placed yet, `preview`) are skipped; a point
//! without `positionStatus` is defined (the schema's default).
//!
//! **`.fcsv`.** Comment lines `# CoordinateSystem = LPS | RAS | 0 | 1`
//! (`0` is RAS, `1` LPS, as Slicer 4.x wrote them; a file without this line,
//! written before Slicer 4.11, is RAS) and `# columns = id,x,y,z,...,label,
//! ...` (default: Slicer's `id,x,y,z,ow,ox,oy,oz,vis,sel,lock,label,desc,
//! associatedNodeID`), then one comma-separated line per point (fields may
//! be double-quoted).
//!
//! **Frame.** unfold's coordinates are RAS (the NIfTI world frame): an LPS
//! point `(x, y, z)` becomes `(-x, -y, z)`.
//!
//! Points are looked up by label, case-insensitively and with surrounding
//! spaces ignored ([`Markups::find`], [`Markups::require`]); a caller names
//! the labels (and synonyms) it accepts.

use crate::{FilePath, IoError};
use serde::Deserialize;
use std::path::Path;
use thiserror::Error;
use unfold_mesh::nalgebra::Point3;

/// What can be wrong with a markups file (reaches callers as
/// [`IoError::Markups`], with the file's path).
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum MarkupsError {
    /// The file is not JSON.
    #[error(
        "not a JSON file (line {line}, column {column}: {message}); expected a Slicer .mrk.json"
    )]
    NotJson {
        /// 1-based line of the problem.
        line: usize,
        /// 1-based column of the problem.
        column: usize,
        /// What the JSON parser said.
        message: String,
    },
    /// JSON, but not Slicer's markups schema.
    #[error("not a Slicer markups file: {message}")]
    Schema {
        /// What does not fit the schema.
        message: String,
    },
    /// No markup, or no placed control point.
    #[error("has no markups control points (an empty \"markups\" list or no placed points)")]
    NoMarkups,
    /// A coordinate system other than LPS or RAS.
    #[error("coordinate system {found:?} (known: LPS, RAS)")]
    CoordinateSystem {
        /// What the file says.
        found: String,
    },
    /// A length unit other than mm or um.
    #[error("coordinate units {found:?} (known: mm, um)")]
    Units {
        /// What the file says.
        found: String,
    },
    /// A control point's position is not three numbers.
    #[error("control point {label:?} has a position of {len} numbers (3 needed)")]
    Position {
        /// The point's label.
        label: String,
        /// How many numbers it has.
        len: usize,
    },
    /// A control point's position is not finite.
    #[error("control point {label:?} has a non-finite position {position:?}")]
    NotFinite {
        /// The point's label.
        label: String,
        /// Its position as read.
        position: [f64; 3],
    },
    /// A needed point is missing.
    #[error("has no point labelled {}; labels found: {}", names(.accepted), names(.found))]
    Missing {
        /// The labels accepted for it (the name first, then synonyms).
        accepted: Vec<String>,
        /// Every label in the file.
        found: Vec<String>,
    },
    /// Several points carry a needed label.
    #[error(
        "has {count} points labelled {} (labels {}); keep one",
        names(.accepted),
        names(.labels)
    )]
    Duplicate {
        /// The labels accepted for it.
        accepted: Vec<String>,
        /// How many points matched.
        count: usize,
        /// Their labels as written.
        labels: Vec<String>,
    },
    /// A `.fcsv` line cannot be read.
    #[error("line {line}: {message}")]
    Fcsv {
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// `"a", "b"`, or `(none)`.
fn names(v: &[String]) -> String {
    if v.is_empty() {
        return "(none)".into();
    }
    v.iter()
        .map(|s| format!("{s:?}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The frame a file's positions are given in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CoordinateSystem {
    /// Right, anterior, superior (unfold's frame).
    Ras,
    /// Left, posterior, superior (DICOM's; Slicer's default in files).
    Lps,
}

impl CoordinateSystem {
    /// The RAS point of `p` given in this frame: LPS `(x, y, z)` is RAS
    /// `(-x, -y, z)` (the map is its own inverse).
    pub fn to_ras(self, p: [f64; 3]) -> [f64; 3] {
        match self {
            CoordinateSystem::Ras => p,
            CoordinateSystem::Lps => [-p[0], -p[1], p[2]],
        }
    }
}

/// One placed control point.
#[derive(Debug, Clone, PartialEq)]
pub struct ControlPoint {
    /// Its label as written.
    pub label: String,
    /// Its position, RAS, mm.
    pub position: Point3<f64>,
}

/// The placed control points of a markups file, RAS, mm.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Markups {
    /// Every placed point, in file order.
    pub points: Vec<ControlPoint>,
}

#[derive(Deserialize)]
struct FileJson {
    markups: Option<Vec<MarkupJson>>,
}

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct MarkupJson {
    coordinate_system: Option<String>,
    coordinate_units: Option<serde_json::Value>,
    #[serde(default)]
    control_points: Vec<PointJson>,
}

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct PointJson {
    #[serde(default)]
    label: String,
    #[serde(default)]
    position: Vec<f64>,
    position_status: Option<String>,
}

/// `LPS` / `RAS` (any case).
fn system(s: &str) -> Result<CoordinateSystem, MarkupsError> {
    match s.trim().to_ascii_uppercase().as_str() {
        "LPS" => Ok(CoordinateSystem::Lps),
        "RAS" => Ok(CoordinateSystem::Ras),
        _ => Err(MarkupsError::CoordinateSystem { found: s.into() }),
    }
}

/// A placed point, checked: three finite numbers, times `scale`, to RAS.
fn point(
    label: &str,
    position: &[f64],
    scale: f64,
    frame: CoordinateSystem,
) -> Result<ControlPoint, MarkupsError> {
    let &[x, y, z] = position else {
        return Err(MarkupsError::Position {
            label: label.into(),
            len: position.len(),
        });
    };
    let p = [x * scale, y * scale, z * scale];
    if !p.iter().all(|v| v.is_finite()) {
        return Err(MarkupsError::NotFinite {
            label: label.into(),
            position: [x, y, z],
        });
    }
    let [a, b, c] = frame.to_ras(p);
    Ok(ControlPoint {
        label: label.into(),
        position: Point3::new(a, b, c),
    })
}

impl Markups {
    /// Parses a `.mrk.json` file's bytes.
    ///
    /// # Errors
    /// [`MarkupsError::NotJson`], [`MarkupsError::Schema`],
    /// [`MarkupsError::NoMarkups`], [`MarkupsError::CoordinateSystem`],
    /// [`MarkupsError::Units`], [`MarkupsError::Position`],
    /// [`MarkupsError::NotFinite`].
    pub fn from_json(bytes: &[u8]) -> Result<Markups, MarkupsError> {
        let value: serde_json::Value =
            serde_json::from_slice(bytes).map_err(|e| MarkupsError::NotJson {
                line: e.line(),
                column: e.column(),
                message: e.to_string(),
            })?;
        let file: FileJson = serde_json::from_value(value).map_err(|e| MarkupsError::Schema {
            message: e.to_string(),
        })?;
        let mut points = Vec::new();
        for m in file.markups.unwrap_or_default() {
            let frame = match &m.coordinate_system {
                Some(s) => system(s)?,
                None => CoordinateSystem::Lps,
            };
            let unit = match &m.coordinate_units {
                None => "mm".to_string(),
                Some(serde_json::Value::String(s)) => s.clone(),
                Some(serde_json::Value::Array(a)) => match a.first() {
                    Some(serde_json::Value::String(s)) => s.clone(),
                    _ => serde_json::Value::Array(a.clone()).to_string(),
                },
                Some(other) => other.to_string(),
            };
            let scale = match unit.trim() {
                "mm" => 1.0,
                "um" => 1e-3,
                _ => return Err(MarkupsError::Units { found: unit }),
            };
            for p in &m.control_points {
                if p.position_status.as_deref().is_some_and(|s| s != "defined") {
                    continue;
                }
                points.push(point(&p.label, &p.position, scale, frame)?);
            }
        }
        if points.is_empty() {
            return Err(MarkupsError::NoMarkups);
        }
        Ok(Markups { points })
    }

    /// Parses a `.fcsv` file's text.
    ///
    /// # Errors
    /// [`MarkupsError::Fcsv`] for a line that cannot be read,
    /// [`MarkupsError::CoordinateSystem`], [`MarkupsError::NotFinite`],
    /// [`MarkupsError::NoMarkups`].
    pub fn from_fcsv(text: &str) -> Result<Markups, MarkupsError> {
        let mut frame = CoordinateSystem::Ras;
        let mut columns: Vec<String> =
            "id,x,y,z,ow,ox,oy,oz,vis,sel,lock,label,desc,associatedNodeID"
                .split(',')
                .map(str::to_string)
                .collect();
        let mut points = Vec::new();
        for (k, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() {
                continue;
            }
            if let Some(comment) = line.strip_prefix('#') {
                if let Some((key, value)) = comment.split_once('=') {
                    match key.trim().to_ascii_lowercase().as_str() {
                        "coordinatesystem" => {
                            frame = match value.trim() {
                                "0" => CoordinateSystem::Ras,
                                "1" => CoordinateSystem::Lps,
                                v => system(v)?,
                            }
                        }
                        "columns" => {
                            columns = value.split(',').map(|c| c.trim().to_string()).collect()
                        }
                        _ => {}
                    }
                }
                continue;
            }
            let fields = split_csv(line);
            let column =
                |name: &str| -> Result<&str, MarkupsError> {
                    let i = columns.iter().position(|c| c == name).ok_or_else(|| {
                        MarkupsError::Fcsv {
                            line: k + 1,
                            message: format!("no column {name:?} in the columns header"),
                        }
                    })?;
                    fields.get(i).map(String::as_str).ok_or(MarkupsError::Fcsv {
                        line: k + 1,
                        message: format!(
                            "{} fields; column {name:?} is number {}",
                            fields.len(),
                            i + 1
                        ),
                    })
                };
            let mut xyz = [0.0; 3];
            for (a, name) in ["x", "y", "z"].iter().enumerate() {
                let f = column(name)?;
                xyz[a] = f.trim().parse().map_err(|_| MarkupsError::Fcsv {
                    line: k + 1,
                    message: format!("{name} = {f:?} is not a number"),
                })?;
            }
            let label = column("label")?.to_string();
            points.push(point(&label, &xyz, 1.0, frame)?);
        }
        if points.is_empty() {
            return Err(MarkupsError::NoMarkups);
        }
        Ok(Markups { points })
    }

    /// The point labelled by one of `accepted` (case-insensitive, spaces
    /// around ignored), or `None`.
    ///
    /// # Errors
    /// [`MarkupsError::Duplicate`] when several points carry such a label.
    pub fn find(&self, accepted: &[&str]) -> Result<Option<Point3<f64>>, MarkupsError> {
        let hits: Vec<&ControlPoint> = self
            .points
            .iter()
            .filter(|p| {
                let l = p.label.trim();
                accepted.iter().any(|a| l.eq_ignore_ascii_case(a))
            })
            .collect();
        match hits.as_slice() {
            [] => Ok(None),
            [p] => Ok(Some(p.position)),
            many => Err(MarkupsError::Duplicate {
                accepted: accepted.iter().map(|s| s.to_string()).collect(),
                count: many.len(),
                labels: many.iter().map(|p| p.label.clone()).collect(),
            }),
        }
    }

    /// As [`Markups::find`], for a point that must be there.
    ///
    /// # Errors
    /// [`MarkupsError::Missing`] (listing the labels found) or
    /// [`MarkupsError::Duplicate`].
    pub fn require(&self, accepted: &[&str]) -> Result<Point3<f64>, MarkupsError> {
        self.find(accepted)?.ok_or_else(|| MarkupsError::Missing {
            accepted: accepted.iter().map(|s| s.to_string()).collect(),
            found: self.points.iter().map(|p| p.label.clone()).collect(),
        })
    }
}

/// Splits one CSV line at commas outside double quotes (`""` inside quotes
/// is a quote).
fn split_csv(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' if quoted && chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(std::mem::take(&mut cur)),
            c => cur.push(c),
        }
    }
    out.push(cur);
    out
}

/// Reads a markups file: `.fcsv` by its extension, JSON otherwise
/// (`.mrk.json`, `.json`).
///
/// # Errors
/// [`IoError::Io`] when the file cannot be read, [`IoError::Markups`] for
/// its content.
pub fn read_markups(path: impl AsRef<Path>) -> Result<Markups, IoError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| IoError::Io {
        path: FilePath(path.into()),
        source,
    })?;
    let fcsv = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("fcsv"));
    let parsed = if fcsv {
        Markups::from_fcsv(&String::from_utf8_lossy(&bytes))
    } else {
        Markups::from_json(&bytes)
    };
    parsed.map_err(|source| IoError::Markups {
        path: FilePath(path.into()),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A `.mrk.json` of `points` (label, position) in `frame`, the way
    /// Slicer writes it (tests only).
    fn mrk_json(points: &[(&str, [f64; 3])], frame: Option<&str>) -> String {
        let cps: Vec<serde_json::Value> = points
            .iter()
            .enumerate()
            .map(|(k, (label, p))| {
                serde_json::json!({
                    "id": (k + 1).to_string(), "label": label, "description": "",
                    "associatedNodeID": "", "position": p,
                    "orientation": [-1.0, -0.0, -0.0, -0.0, -1.0, -0.0, 0.0, 0.0, 1.0],
                    "selected": true, "locked": false, "visibility": true,
                    "positionStatus": "defined"
                })
            })
            .collect();
        let mut markup = serde_json::json!({
            "type": "Fiducial", "coordinateUnits": "mm", "locked": false,
            "labelFormat": "%N-%d", "controlPoints": cps,
            "measurements": [], "display": {"visibility": true}
        });
        if let Some(f) = frame {
            markup["coordinateSystem"] = serde_json::json!(f);
        }
        serde_json::json!({
            "@schema": "https://raw.githubusercontent.com/slicer/slicer/master/Modules/Loadable/Markups/Resources/Schema/markups-schema-v1.0.3.json#",
            "markups": [markup]
        })
        .to_string()
    }

    fn lps(p: [f64; 3]) -> [f64; 3] {
        [-p[0], -p[1], p[2]]
    }

    #[test]
    fn slicer_points_are_read_by_label_in_ras() {
        let a = [14.5, 20.25, -0.5];
        let i = [-3.0, 7.0, 1.0];
        let x = [0.0, 0.0, -60.0];
        let text = mrk_json(
            &[("Anterior", lps(a)), ("inferior ", lps(i)), ("F-3", lps(x))],
            Some("LPS"),
        );
        let m = Markups::from_json(text.as_bytes()).unwrap();
        assert_eq!(m.points.len(), 3);
        assert_eq!(m.require(&["anterior"]).unwrap(), Point3::from(a));
        assert_eq!(m.require(&["INFERIOR"]).unwrap(), Point3::from(i));
        assert_eq!(m.find(&["apex"]).unwrap(), None);
        assert_eq!(m.find(&["apex", "F-3"]).unwrap(), Some(Point3::from(x)));
        // the same file in RAS, and without a coordinate system (LPS)
        let ras = mrk_json(&[("anterior", a)], Some("RAS"));
        let m = Markups::from_json(ras.as_bytes()).unwrap();
        assert_eq!(m.require(&["anterior"]).unwrap(), Point3::from(a));
        let default = mrk_json(&[("anterior", lps(a))], None);
        let m = Markups::from_json(default.as_bytes()).unwrap();
        assert_eq!(m.require(&["anterior"]).unwrap(), Point3::from(a));
    }

    #[test]
    fn units_status_and_several_markups() {
        let text = r#"{"@schema": "x", "markups": [
            {"type": "Fiducial", "coordinateSystem": "RAS", "coordinateUnits": "um",
             "controlPoints": [{"label": "apex", "position": [1000.0, -2000.0, 500.0]},
                               {"label": "anterior", "position": [0, 0, 0], "positionStatus": "undefined"}]},
            {"type": "Curve", "coordinateSystem": "RAS",
             "coordinateUnits": ["mm", "UCUM", "millimeter"],
             "controlPoints": [{"label": "anterior", "position": [1, 2, 3]}]}]}"#;
        let m = Markups::from_json(text.as_bytes()).unwrap();
        assert_eq!(m.points.len(), 2);
        assert_eq!(m.require(&["apex"]).unwrap(), Point3::new(1.0, -2.0, 0.5));
        assert_eq!(
            m.require(&["anterior"]).unwrap(),
            Point3::new(1.0, 2.0, 3.0)
        );
    }

    /// Whether an error is the one expected.
    type Check = fn(&MarkupsError) -> bool;

    #[test]
    fn bad_files_give_typed_one_line_errors() {
        let cases: Vec<(&str, Check, &str)> = vec![
            (
                "{\"markups\": [",
                |e| matches!(e, MarkupsError::NotJson { line: 1, .. }),
                "not a JSON file",
            ),
            (
                "anterior,1,2,3",
                |e| matches!(e, MarkupsError::NotJson { .. }),
                "not a JSON file",
            ),
            (
                "{\"markups\": 3}",
                |e| matches!(e, MarkupsError::Schema { .. }),
                "not a Slicer markups file",
            ),
            (
                "{\"markups\": []}",
                |e| matches!(e, MarkupsError::NoMarkups),
                "no markups",
            ),
            (
                "{\"@schema\": \"x\"}",
                |e| matches!(e, MarkupsError::NoMarkups),
                "no markups",
            ),
            (
                r#"{"markups": [{"coordinateSystem": "XYZ", "controlPoints": []}]}"#,
                |e| matches!(e, MarkupsError::CoordinateSystem { .. }),
                "\"XYZ\"",
            ),
            (
                r#"{"markups": [{"coordinateUnits": "cm", "controlPoints": []}]}"#,
                |e| matches!(e, MarkupsError::Units { .. }),
                "\"cm\"",
            ),
            (
                r#"{"markups": [{"controlPoints": [{"label": "a", "position": [1, 2]}]}]}"#,
                |e| matches!(e, MarkupsError::Position { len: 2, .. }),
                "2 numbers",
            ),
            (
                r#"{"markups": [{"controlPoints": [{"label": "a", "position": [1e999, 2, 3]}]}]}"#,
                |e| matches!(e, MarkupsError::NotJson { .. }),
                "out of range",
            ),
        ];
        for (text, is, want) in cases {
            let e = Markups::from_json(text.as_bytes()).unwrap_err();
            assert!(is(&e), "{text}: {e:?}");
            let m = e.to_string();
            assert!(m.contains(want), "{text}: {m}");
            assert!(!m.contains('\n'), "{m}");
        }
        // a huge finite value is kept (negated in LPS)
        let m = Markups::from_json(
            br#"{"markups": [{"controlPoints": [{"label": "a", "position": [1e308, 2, 3]}]}]}"#,
        )
        .unwrap();
        assert_eq!(m.points[0].position.x, -1e308);
    }

    #[test]
    fn missing_and_duplicate_labels_name_what_was_found() {
        let text = mrk_json(
            &[("F-1", [0.0; 3]), ("Apex", [1.0; 3]), ("apex", [2.0; 3])],
            Some("RAS"),
        );
        let m = Markups::from_json(text.as_bytes()).unwrap();
        let e = m.require(&["anterior", "ant"]).unwrap_err();
        assert_eq!(
            e,
            MarkupsError::Missing {
                accepted: vec!["anterior".into(), "ant".into()],
                found: vec!["F-1".into(), "Apex".into(), "apex".into()],
            }
        );
        let s = e.to_string();
        assert!(
            s.contains("\"anterior\"") && s.contains("\"F-1\", \"Apex\", \"apex\""),
            "{s}"
        );
        let e = m.find(&["apex"]).unwrap_err();
        assert!(
            matches!(e, MarkupsError::Duplicate { count: 2, .. }),
            "{e:?}"
        );
        assert!(e.to_string().contains("2 points labelled \"apex\""), "{e}");
    }

    #[test]
    fn fcsv_files_are_read_in_either_frame() {
        let old = "# Markups fiducial file version = 4.6\n\
                   # CoordinateSystem = 0\n\
                   # columns = id,x,y,z,ow,ox,oy,oz,vis,sel,lock,label,desc,associatedNodeID\n\
                   vtkMRMLMarkupsFiducialNode_0,1.5,-2,3,0,0,0,1,1,1,0,anterior,,\n\
                   vtkMRMLMarkupsFiducialNode_1,4,5,6,0,0,0,1,1,1,0,\"apex, tip\",\"a \"\"note\"\"\",\n";
        let m = Markups::from_fcsv(old).unwrap();
        assert_eq!(
            m.require(&["anterior"]).unwrap(),
            Point3::new(1.5, -2.0, 3.0)
        );
        assert_eq!(
            m.require(&["apex, tip"]).unwrap(),
            Point3::new(4.0, 5.0, 6.0)
        );
        let lps = old.replace("CoordinateSystem = 0", "CoordinateSystem = LPS");
        let m = Markups::from_fcsv(&lps).unwrap();
        assert_eq!(
            m.require(&["anterior"]).unwrap(),
            Point3::new(-1.5, 2.0, 3.0)
        );
        let no_header = "a,1,2,3,0,0,0,1,1,1,0,anterior,,\n";
        let m = Markups::from_fcsv(no_header).unwrap();
        assert_eq!(
            m.require(&["anterior"]).unwrap(),
            Point3::new(1.0, 2.0, 3.0)
        );
        let e = Markups::from_fcsv("a,nan,2,3,0,0,0,1,1,1,0,anterior,,\n").unwrap_err();
        assert!(matches!(e, MarkupsError::NotFinite { .. }), "{e:?}");
        let e = Markups::from_fcsv("a,x,2,3,0,0,0,1,1,1,0,anterior,,\n").unwrap_err();
        assert!(matches!(e, MarkupsError::Fcsv { line: 1, .. }), "{e:?}");
        assert!(e.to_string().contains("not a number"), "{e}");
        let e = Markups::from_fcsv("a,1,2\n").unwrap_err();
        assert!(matches!(e, MarkupsError::Fcsv { .. }), "{e:?}");
        assert_eq!(
            Markups::from_fcsv("# nothing\n"),
            Err(MarkupsError::NoMarkups)
        );
    }

    #[test]
    fn read_markups_names_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("l.mrk.json");
        std::fs::write(&p, "not json").unwrap();
        let e = read_markups(&p).unwrap_err();
        assert!(
            matches!(
                e,
                IoError::Markups {
                    source: MarkupsError::NotJson { .. },
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(e.to_string().starts_with(&p.display().to_string()), "{e}");
        let e = read_markups(dir.path().join("missing.mrk.json")).unwrap_err();
        assert!(matches!(e, IoError::Io { .. }), "{e:?}");
        let f = dir.path().join("l.FCSV");
        std::fs::write(&f, "a,1,2,3,0,0,0,1,1,1,0,apex,,\n").unwrap();
        assert_eq!(
            read_markups(&f).unwrap().require(&["apex"]).unwrap(),
            Point3::new(1.0, 2.0, 3.0)
        );
    }

    proptest! {
        /// Written in LPS or RAS and read back, every point is where it was
        /// (RAS); LPS to RAS twice is the identity.
        #[test]
        fn points_round_trip_through_either_frame(
            pts in proptest::collection::vec(proptest::array::uniform3(-500.0..500.0f64), 1..6),
            as_lps in any::<bool>(),
        ) {
            let labels: Vec<String> = (0..pts.len()).map(|k| format!("P{k}")).collect();
            let frame = if as_lps { CoordinateSystem::Lps } else { CoordinateSystem::Ras };
            let written: Vec<(&str, [f64; 3])> = labels
                .iter()
                .zip(&pts)
                .map(|(l, p)| (l.as_str(), frame.to_ras(*p)))
                .collect();
            let text = mrk_json(&written, Some(if as_lps { "LPS" } else { "RAS" }));
            let m = Markups::from_json(text.as_bytes()).unwrap();
            for (l, p) in labels.iter().zip(&pts) {
                let q = m.require(&[&l.to_lowercase()]).unwrap();
                prop_assert_eq!(q, Point3::from(*p));
                prop_assert_eq!(frame.to_ras(frame.to_ras(*p)), *p);
            }
        }
    }
}

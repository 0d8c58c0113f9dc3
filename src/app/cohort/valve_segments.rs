//! The Carpentier-segment means of one valve map (the mitral counterpart
//! of a heart's AHA-segment means, [`super::segments`]): for each scalar
//! array of `valve2d.vtu` and each segment `k` of A1-A3, P1-P3 (the point
//! array `carpentier`, 1-6; ALGORITHMS 4.5), the mean of the array's
//! finite values over the segment:
//!
//! - a point array (`length_energy`, `coaptation_distance_mm`,
//!   `tenting_mm`, ...) over the vertices labelled `k`;
//! - a cell array (`area_energy`, `angle_energy`, ...) over the triangles
//!   whose vertices are mostly labelled `k` (a tie goes to the smallest
//!   label).
//!
//! Integer arrays are labels (`leaflet`, `checker`, `coaptation`, ...), not
//! quantities, and arrays of several components (`u_gradient`, `uv`) are
//! left out.

use crate::app::error::{AppError, at};
use crate::mesh::{CellMesh, Field, FieldValues};
use std::collections::BTreeMap;
use std::path::Path;

/// The Carpentier labels, A1-A3 then P1-P3.
pub const SEGMENTS: [i32; 6] = [1, 2, 3, 4, 5, 6];

/// The name of Carpentier label `k` (`A1` .. `P3`; `?` outside 1-6).
pub fn segment_name(k: i32) -> &'static str {
    match k {
        1 => "A1",
        2 => "A2",
        3 => "A3",
        4 => "P1",
        5 => "P2",
        6 => "P3",
        _ => "?",
    }
}

/// Whether `f` holds a quantity to average: one component of floats.
fn is_quantity(f: &Field) -> bool {
    f.components() == 1 && matches!(f.values(), FieldValues::F64(_) | FieldValues::F32(_))
}

/// The label of a triangle: the one most of its vertices carry (a tie to
/// the smallest); `None` if no vertex has a label in 1-6.
fn cell_label(vertices: &[u32], labels: &Field) -> Option<i32> {
    let mut counts = [0usize; 7];
    for &v in vertices {
        if let Some(l) = labels.get(v as usize, 0) {
            let l = l as i32;
            if SEGMENTS.contains(&l) {
                counts[l as usize] += 1;
            }
        }
    }
    let best = counts.iter().copied().max().unwrap_or(0);
    (best > 0).then(|| SEGMENTS.into_iter().find(|&k| counts[k as usize] == best))?
}

/// Adds the finite values of `f` at `(element, label)` pairs into `sums`.
fn accumulate(
    f: &Field,
    labelled: impl Iterator<Item = (usize, Option<i32>)>,
    sums: &mut BTreeMap<(String, i32), (f64, usize)>,
) {
    for (i, label) in labelled {
        let (Some(k), Some(v)) = (label, f.get(i, 0)) else {
            continue;
        };
        if v.is_finite() {
            let e = sums.entry((f.name().to_string(), k)).or_default();
            e.0 += v;
            e.1 += 1;
        }
    }
}

/// `(array, segment) -> mean` of a valve map with the point array
/// `carpentier` (module documentation); `None` without it.
pub fn valve_segments(mesh: &CellMesh) -> Option<BTreeMap<(String, i32), f64>> {
    let labels = mesh.point_data.get("carpentier")?;
    let point_label = |i: usize| {
        labels
            .get(i, 0)
            .map(|l| l as i32)
            .filter(|l| SEGMENTS.contains(l))
    };
    let mut sums = BTreeMap::new();
    for f in mesh.point_data.iter().filter(|f| is_quantity(f)) {
        accumulate(f, (0..f.tuples()).map(|i| (i, point_label(i))), &mut sums);
    }
    let cell_labels: Vec<Option<i32>> = mesh.cells().map(|(_, v)| cell_label(v, labels)).collect();
    for f in mesh.cell_data.iter().filter(|f| is_quantity(f)) {
        accumulate(f, cell_labels.iter().copied().enumerate(), &mut sums);
    }
    Some(
        sums.into_iter()
            .map(|(k, (s, n))| (k, s / n as f64))
            .collect(),
    )
}

/// The segment means of the valve map `dir/valve2d.vtu`.
///
/// # Errors
/// Reading the map; a map without the `carpentier` point array.
pub fn valve_means(dir: &Path) -> Result<BTreeMap<(String, i32), f64>, AppError> {
    let path = dir.join("valve2d.vtu");
    let mesh = crate::io::read_mesh(&path)?;
    valve_segments(&mesh).ok_or_else(|| at(&path, "has no 'carpentier' point array"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::CellType;
    use crate::mesh::nalgebra::Point3;

    /// Two triangles: one in A1 (all vertices 1), one mostly P2 (labels 5,
    /// 5, 1), one vertex unlabelled (0).
    fn valve() -> CellMesh {
        let mut m = CellMesh::from_points(vec![Point3::origin(); 6]);
        m.push_cell(CellType::Triangle, &[0, 1, 2]);
        m.push_cell(CellType::Triangle, &[3, 4, 0]);
        m.add_point_field(Field::labels("carpentier", vec![1, 1, 1, 5, 5, 0]))
            .unwrap();
        m.add_point_field(Field::labels("leaflet", vec![0, 0, 0, 1, 1, 1]))
            .unwrap();
        m.add_point_field(Field::scalars(
            "tenting_mm",
            vec![1.0, 2.0, 3.0, 10.0, f64::NAN, 7.0],
        ))
        .unwrap();
        m.add_cell_field(Field::scalars("area_energy", vec![0.5, 4.0]))
            .unwrap();
        m
    }

    #[test]
    fn point_and_cell_arrays_average_over_their_segments() {
        let means = valve_segments(&valve()).unwrap();
        let get = |a: &str, k: i32| means.get(&(a.to_string(), k)).copied();
        assert_eq!(get("tenting_mm", 1), Some(2.0));
        // P2's NaN is no measurement; the unlabelled vertex counts nowhere.
        assert_eq!(get("tenting_mm", 5), Some(10.0));
        assert_eq!(get("area_energy", 1), Some(0.5));
        assert_eq!(get("area_energy", 5), Some(4.0));
        assert!(
            means
                .keys()
                .all(|(a, _)| a != "leaflet" && a != "carpentier")
        );
        assert_eq!(means.len(), 4);
        assert_eq!(segment_name(5), "P2");
    }

    #[test]
    fn a_map_without_labels_has_no_segments_and_a_tie_goes_to_the_smaller_label() {
        let mut m = valve();
        m.point_data = Default::default();
        assert!(valve_segments(&m).is_none());
        let labels = Field::labels("carpentier", vec![2, 4, 0]);
        assert_eq!(cell_label(&[0, 1, 2], &labels), Some(2));
        assert_eq!(cell_label(&[2, 2, 2], &labels), None);
    }
}

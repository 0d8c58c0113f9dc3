//! What every placenta figure needs from the outcome, checked once: both
//! meshes, the aligned original, the boundary, the rotation, the `side`
//! labels and `log2 det J`.

use super::MESH_FIGURES;
use super::numbers::{ceil_2, percentile};
use crate::figures::FigureError;
use crate::mesh::geometry::tet_signed_volume;
use crate::mesh::nalgebra::{Point3, Rotation3};
use crate::mesh::topology::tet_boundary;
use crate::mesh::{Field, TetMesh};
use crate::organs::placenta::Outcome;

/// What every figure needs from the outcome, checked once.
pub(super) struct Meshes<'a> {
    /// Original positions (scanner frame).
    pub(super) original: &'a [Point3<f64>],
    /// Flattened positions (template frame).
    pub(super) flattened: &'a [Point3<f64>],
    /// The original after the rigid alignment (template axes).
    pub(super) aligned: Vec<Point3<f64>>,
    /// The tets (shared by both meshes).
    pub(super) tets: &'a [[u32; 4]],
    /// Boundary triangles in volume vertex indices.
    pub(super) tris: Vec<[u32; 3]>,
    /// The tet of each boundary triangle.
    pub(super) face_tet: Vec<u32>,
    /// Scanner -> template rotation.
    pub(super) rotation: Rotation3<f64>,
    /// Per vertex `side` labels, when known.
    pub(super) labels: Option<Vec<u8>>,
    /// Per tet `log2 det J`.
    pub(super) log2_det_j: Vec<f64>,
    /// Half range of the `log2 det J` colour scale.
    pub(super) det_j_range: f64,
}

impl<'a> Meshes<'a> {
    pub(super) fn new(outcome: &'a Outcome) -> Result<Self, FigureError> {
        let bad = |what: String| FigureError::input(MESH_FIGURES, what);
        let (orig, flat) = (&outcome.original, &outcome.flattened);
        let n = flat.positions.len();
        if orig.positions.len() != n {
            return Err(bad(format!(
                "the original mesh has {} vertices, the flattened one {n}",
                orig.positions.len()
            )));
        }
        if flat.tets.is_empty() {
            return Err(bad("the flattened mesh has no tetrahedra".into()));
        }
        for (what, p) in [
            ("original", &orig.positions),
            ("flattened", &flat.positions),
        ] {
            if let Some(v) = p
                .iter()
                .position(|q| !q.coords.iter().all(|x| x.is_finite()))
            {
                return Err(bad(format!("vertex {v} of the {what} mesh is not finite")));
            }
        }
        let bare = TetMesh::new(flat.positions.clone(), flat.tets.clone());
        let boundary =
            tet_boundary(&bare).map_err(|e| bad(format!("the flattened mesh's boundary: {e}")))?;
        let tris: Vec<[u32; 3]> = boundary
            .surface
            .triangles
            .iter()
            .map(|t| t.map(|v| boundary.to_volume[v as usize]))
            .collect();
        if tris.is_empty() {
            return Err(bad("the flattened mesh has no boundary".into()));
        }
        let rotation = outcome.alignment.rotation();
        let rotation = if rotation.matrix().iter().all(|x| x.is_finite()) {
            rotation
        } else {
            Rotation3::identity()
        };
        let aligned: Vec<Point3<f64>> = orig
            .positions
            .iter()
            .map(|p| outcome.alignment.apply(p))
            .collect();
        let aligned = if aligned
            .iter()
            .all(|p| p.coords.iter().all(|x| x.is_finite()))
        {
            aligned
        } else {
            orig.positions.clone()
        };
        let labels = side_labels(outcome, n);
        let log2_det_j = match scalar_field(flat.cell_data.get("log2_det_j"), flat.tets.len()) {
            Some(v) => v,
            None => volume_ratios(&orig.positions, &flat.positions, &flat.tets),
        };
        let det_j_range = symmetric_range(&log2_det_j);
        Ok(Meshes {
            original: &orig.positions,
            flattened: &flat.positions,
            aligned,
            tets: &flat.tets,
            tris,
            face_tet: boundary.face_tet,
            rotation,
            labels,
            log2_det_j,
            det_j_range,
        })
    }
}

/// The `side` labels: the original's point array, else the flattened one's,
/// else `outcome.labels`, whichever has one value per vertex.
fn side_labels(outcome: &Outcome, n: usize) -> Option<Vec<u8>> {
    for mesh in [&outcome.original, &outcome.flattened] {
        if let Some(v) = scalar_field(mesh.point_data.get("side"), n) {
            return Some(
                v.iter()
                    .map(|&x| {
                        if x.is_finite() && (0.0..=254.0).contains(&x) && x.fract() == 0.0 {
                            x as u8
                        } else {
                            u8::MAX
                        }
                    })
                    .collect(),
            );
        }
    }
    (outcome.labels.len() == n && n > 0).then(|| outcome.labels.clone())
}

/// The values of a one-component field with `n` tuples.
fn scalar_field(field: Option<&Field>, n: usize) -> Option<Vec<f64>> {
    let f = field?;
    (f.components() == 1 && f.tuples() == n).then(|| f.values().to_f64())
}

/// `log2` of the flattened over the original signed tet volume (`det J` of
/// the linear map), `-inf` for a flattened tet with volume `<= 0`.
fn volume_ratios(orig: &[Point3<f64>], flat: &[Point3<f64>], tets: &[[u32; 4]]) -> Vec<f64> {
    tets.iter()
        .map(|t| {
            let [a, b, c, d] = t.map(|i| i as usize);
            let vo = tet_signed_volume(&orig[a], &orig[b], &orig[c], &orig[d]);
            let vf = tet_signed_volume(&flat[a], &flat[b], &flat[c], &flat[d]);
            if vf <= 0.0 {
                f64::NEG_INFINITY
            } else {
                (vf / vo).log2()
            }
        })
        .collect()
}

/// The half range `m` of a symmetric scale `[-m, m]` for `values`: the 99th
/// percentile of the finite `|v|` (a few extreme tets do not wash the map
/// out; they take the end colours), at least `1e-3`, rounded up to two
/// significant digits.
fn symmetric_range(values: &[f64]) -> f64 {
    let mut abs: Vec<f64> = values
        .iter()
        .filter(|v| v.is_finite())
        .map(|v| v.abs())
        .collect();
    abs.sort_by(f64::total_cmp);
    ceil_2(percentile(&abs, 0.99).unwrap_or(0.0).max(1e-3))
}

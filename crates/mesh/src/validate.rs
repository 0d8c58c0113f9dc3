//! Validation: every problem of a triangle or tet mesh as a typed
//! [`MeshError`], with how often it occurs.
//!
//! The checks never panic, whatever the mesh: elements with out-of-range
//! indices are reported and then left out of every check that would look up
//! their vertices, vertices with non-finite coordinates are left out of the
//! measure checks, and elements with a repeated vertex are left out of the
//! manifold, orientation and measure checks.

use crate::{
    Fields, MeshError, TetMesh, TriMesh,
    geometry::{tet_signed_volume, triangle_area},
    topology::connected_components,
};
use nalgebra::Point3;
use std::fmt;

/// What [`check_tri_mesh`] and [`check_tet_mesh`] look for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValidationOptions {
    /// An element is degenerate when `|measure| < degenerate_rel × mean
    /// |measure|` (area for triangles, volume for tets, mean over the
    /// checkable elements) or `measure == 0`. Default `1e-12`.
    pub degenerate_rel: f64,
    /// Do not report vertices used by no element. Default `false`.
    pub allow_unused_vertices: bool,
    /// Report a mesh that falls apart into several components. Default
    /// `true`.
    pub require_single_component: bool,
    /// Report triangles that traverse a shared edge in the same direction
    /// (triangle meshes only). Default `true`.
    pub require_consistent_orientation: bool,
}

impl Default for ValidationOptions {
    fn default() -> Self {
        ValidationOptions {
            degenerate_rel: 1e-12,
            allow_unused_vertices: false,
            require_single_component: true,
            require_consistent_orientation: true,
        }
    }
}

/// One kind of problem: its first instance (lowest element / vertex / edge
/// in the order checked) and how many elements, vertices, edges, faces or
/// fields have it (for [`MeshError::MultipleComponents`] the number of
/// components, for [`MeshError::Empty`] 1).
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    /// The first instance.
    pub error: MeshError,
    /// How many instances.
    pub count: usize,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.count > 1 {
            write!(f, "{} ({} in total)", self.error, self.count)
        } else {
            write!(f, "{}", self.error)
        }
    }
}

/// Collects the first instance and the count of one problem kind.
#[derive(Default)]
struct Acc {
    first: Option<MeshError>,
    count: usize,
}

impl Acc {
    fn add(&mut self, error: impl FnOnce() -> MeshError) {
        if self.first.is_none() {
            self.first = Some(error());
        }
        self.count += 1;
    }

    fn push_into(self, out: &mut Vec<Problem>) {
        if let Some(error) = self.first {
            out.push(Problem {
                error,
                count: self.count,
            });
        }
    }
}

/// Element measures used for the degenerate / inverted checks.
#[derive(Clone, Copy)]
enum Measure {
    /// Triangle area `|(b-a)×(c-a)| / 2`.
    Area,
    /// Tet signed volume `(b-a)·((c-a)×(d-a)) / 6`.
    SignedVolume,
}

impl Measure {
    /// "area" or "volume".
    fn name(self) -> &'static str {
        match self {
            Measure::Area => "area",
            Measure::SignedVolume => "volume",
        }
    }

    fn of(self, p: &[Point3<f64>]) -> f64 {
        match self {
            Measure::Area => triangle_area(&p[0], &p[1], &p[2]),
            Measure::SignedVolume => tet_signed_volume(&p[0], &p[1], &p[2], &p[3]),
        }
    }
}

/// All problems of a triangle mesh, most severe first:
/// [`Empty`](MeshError::Empty), [`IndexOutOfRange`](MeshError::IndexOutOfRange),
/// [`NonFiniteCoordinate`](MeshError::NonFiniteCoordinate),
/// [`FieldLength`](MeshError::FieldLength),
/// [`RepeatedVertex`](MeshError::RepeatedVertex),
/// [`NonManifoldEdge`](MeshError::NonManifoldEdge) (an edge with more than two
/// triangles), [`InconsistentOrientation`](MeshError::InconsistentOrientation)
/// (two triangles traversing their shared edge in the same direction),
/// [`NonFiniteMeasure`](MeshError::NonFiniteMeasure) (an element whose
/// measure overflows although its coordinates are finite),
/// [`NonFiniteTotalMeasure`](MeshError::NonFiniteTotalMeasure),
/// [`DegenerateElement`](MeshError::DegenerateElement),
/// [`MultipleComponents`](MeshError::MultipleComponents),
/// [`UnusedVertices`](MeshError::UnusedVertices). At most one [`Problem`] per
/// kind. An empty result means the mesh is valid under `opts`.
pub fn check_tri_mesh(mesh: &TriMesh, opts: &ValidationOptions) -> Vec<Problem> {
    check(
        &mesh.positions,
        &mesh.triangles,
        &mesh.point_data,
        &mesh.cell_data,
        "triangles",
        Measure::Area,
        opts,
        |good, out| {
            let (non_manifold, inconsistent) = triangle_edge_problems(&mesh.triangles, good);
            non_manifold.push_into(out);
            if opts.require_consistent_orientation {
                inconsistent.push_into(out);
            }
        },
    )
}

/// All problems of a tet mesh, most severe first:
/// [`Empty`](MeshError::Empty), [`IndexOutOfRange`](MeshError::IndexOutOfRange),
/// [`NonFiniteCoordinate`](MeshError::NonFiniteCoordinate),
/// [`FieldLength`](MeshError::FieldLength),
/// [`RepeatedVertex`](MeshError::RepeatedVertex),
/// [`NonManifoldFace`](MeshError::NonManifoldFace) (a face with more than two
/// tets), [`NonFiniteMeasure`](MeshError::NonFiniteMeasure) (an element
/// whose measure overflows although its coordinates are finite),
/// [`NonFiniteTotalMeasure`](MeshError::NonFiniteTotalMeasure),
/// [`InvertedElement`](MeshError::InvertedElement) (signed volume
/// `(b-a)·((c-a)×(d-a))/6 < 0`, degenerate and overflowing tets excluded),
/// [`DegenerateElement`](MeshError::DegenerateElement),
/// [`MultipleComponents`](MeshError::MultipleComponents),
/// [`UnusedVertices`](MeshError::UnusedVertices). At most one [`Problem`] per
/// kind. An empty result means the mesh is valid under `opts`.
pub fn check_tet_mesh(mesh: &TetMesh, opts: &ValidationOptions) -> Vec<Problem> {
    check(
        &mesh.positions,
        &mesh.tets,
        &mesh.point_data,
        &mesh.cell_data,
        "tets",
        Measure::SignedVolume,
        opts,
        |good, out| tet_face_problems(&mesh.tets, good).push_into(out),
    )
}

impl TriMesh {
    /// The most severe problem found by [`check_tri_mesh`] with default
    /// [`ValidationOptions`] (single component, consistent orientation, no
    /// unused vertices), or `Ok(())`.
    pub fn validate(&self) -> Result<(), MeshError> {
        first(check_tri_mesh(self, &ValidationOptions::default()))
    }
}

impl TetMesh {
    /// The most severe problem found by [`check_tet_mesh`] with default
    /// [`ValidationOptions`] (single component, no unused vertices), or
    /// `Ok(())`.
    pub fn validate(&self) -> Result<(), MeshError> {
        first(check_tet_mesh(self, &ValidationOptions::default()))
    }
}

fn first(problems: Vec<Problem>) -> Result<(), MeshError> {
    match problems.into_iter().next() {
        Some(p) => Err(p.error),
        None => Ok(()),
    }
}

/// The checks shared by both mesh types; `topology` adds the type-specific
/// manifold / orientation problems for the `good` element rows (in range,
/// no repeated vertex).
#[allow(clippy::too_many_arguments)]
fn check<const K: usize>(
    positions: &[Point3<f64>],
    elements: &[[u32; K]],
    point_data: &Fields,
    cell_data: &Fields,
    what: &'static str,
    measure: Measure,
    opts: &ValidationOptions,
    topology: impl FnOnce(&[usize], &mut Vec<Problem>),
) -> Vec<Problem> {
    let n = positions.len();
    let mut out = Vec::new();

    if n == 0 || elements.is_empty() {
        out.push(Problem {
            error: MeshError::Empty {
                what: if n == 0 { "vertices" } else { what },
            },
            count: 1,
        });
    }

    let mut range = Acc::default();
    let mut in_range = vec![true; elements.len()];
    for (e, el) in elements.iter().enumerate() {
        if let Some(&index) = el.iter().find(|&&v| v as usize >= n) {
            in_range[e] = false;
            range.add(|| MeshError::IndexOutOfRange {
                element: e,
                index,
                vertex_count: n,
            });
        }
    }
    range.push_into(&mut out);

    let mut nonfinite = Acc::default();
    let finite: Vec<bool> = positions
        .iter()
        .map(|p| p.coords.iter().all(|x| x.is_finite()))
        .collect();
    for (v, p) in positions.iter().enumerate() {
        if !finite[v] {
            nonfinite.add(|| MeshError::NonFiniteCoordinate {
                vertex: v,
                x: p.x,
                y: p.y,
                z: p.z,
            });
        }
    }
    nonfinite.push_into(&mut out);

    let mut fields = Acc::default();
    for (data, expected) in [(point_data, n), (cell_data, elements.len())] {
        for f in data {
            if f.tuples() != expected {
                fields.add(|| MeshError::FieldLength {
                    name: f.name().to_string(),
                    expected,
                    found: f.tuples(),
                });
            }
        }
    }
    fields.push_into(&mut out);

    let mut repeated = Acc::default();
    let mut good = Vec::with_capacity(elements.len());
    for (e, el) in elements.iter().enumerate() {
        let mut s = *el;
        s.sort_unstable();
        if let Some(w) = s.windows(2).find(|w| w[0] == w[1]) {
            repeated.add(|| MeshError::RepeatedVertex {
                element: e,
                index: w[0],
            });
        } else if in_range[e] {
            good.push(e);
        }
    }
    repeated.push_into(&mut out);

    topology(&good, &mut out);

    // Measures of the good elements whose corners are all finite; a measure
    // that overflows (coordinates near f64::MAX) is a problem of its own and
    // left out of the degenerate / inverted checks.
    let mut overflow = Acc::default();
    let measured: Vec<(usize, f64)> = good
        .iter()
        .filter(|&&e| elements[e].iter().all(|&v| finite[v as usize]))
        .map(|&e| (e, measure.of(&elements[e].map(|v| positions[v as usize]))))
        .filter(|&(e, m)| {
            if !m.is_finite() {
                overflow.add(|| MeshError::NonFiniteMeasure {
                    what: measure.name(),
                    element: e,
                    value: m,
                });
            }
            m.is_finite()
        })
        .collect();
    overflow.push_into(&mut out);
    let total: f64 = measured.iter().map(|(_, m)| m.abs()).sum();
    if !total.is_finite() {
        out.push(Problem {
            error: MeshError::NonFiniteTotalMeasure {
                what: measure.name(),
                value: total,
            },
            count: 1,
        });
    }
    let mean = if measured.is_empty() || !total.is_finite() {
        0.0
    } else {
        total / measured.len() as f64
    };
    let threshold = opts.degenerate_rel * mean;
    let is_degenerate = |m: f64| m.abs() < threshold || m == 0.0;
    let mut inverted = Acc::default();
    let mut degenerate = Acc::default();
    for &(e, m) in &measured {
        if is_degenerate(m) {
            degenerate.add(|| MeshError::DegenerateElement {
                element: e,
                measure: m,
                threshold,
            });
        } else if matches!(measure, Measure::SignedVolume) && m < 0.0 {
            inverted.add(|| MeshError::InvertedElement {
                element: e,
                volume: m,
            });
        }
    }
    inverted.push_into(&mut out);
    degenerate.push_into(&mut out);

    // Components and unused vertices over the in-range elements.
    let usable: Vec<[u32; K]> = elements
        .iter()
        .zip(&in_range)
        .filter(|(_, ok)| **ok)
        .map(|(el, _)| *el)
        .collect();
    if opts.require_single_component {
        let c = connected_components(n, &usable);
        if c.count > 1 {
            out.push(Problem {
                error: MeshError::MultipleComponents { count: c.count },
                count: c.count,
            });
        }
    }
    if !opts.allow_unused_vertices && !elements.is_empty() {
        let mut used = vec![false; n];
        for el in elements {
            for &v in el {
                if let Some(u) = used.get_mut(v as usize) {
                    *u = true;
                }
            }
        }
        let unused = used.iter().filter(|u| !**u).count();
        if let Some(first) = used.iter().position(|u| !*u) {
            out.push(Problem {
                error: MeshError::UnusedVertices {
                    count: unused,
                    first,
                },
                count: unused,
            });
        }
    }
    out
}

/// Non-manifold edges (more than two triangles) and inconsistently oriented
/// edges (exactly two triangles traversing it the same way) among the
/// triangles `good`, first by edge `(min, max)`.
fn triangle_edge_problems(tris: &[[u32; 3]], good: &[usize]) -> (Acc, Acc) {
    // (min, max, triangle, traversed min -> max)
    let mut half: Vec<(u32, u32, usize, bool)> = Vec::with_capacity(3 * good.len());
    for &t in good {
        let tri = tris[t];
        for i in 0..3 {
            let (a, b) = (tri[i], tri[(i + 1) % 3]);
            half.push((a.min(b), a.max(b), t, a < b));
        }
    }
    crate::topology::bucket_sort(&mut half, |h| h.0);
    let mut non_manifold = Acc::default();
    let mut inconsistent = Acc::default();
    let mut i = 0;
    while i < half.len() {
        let mut j = i + 1;
        while j < half.len() && half[j].0 == half[i].0 && half[j].1 == half[i].1 {
            j += 1;
        }
        let (a, b) = (half[i].0, half[i].1);
        if j - i > 2 {
            non_manifold.add(|| MeshError::NonManifoldEdge { a, b, faces: j - i });
        } else if j - i == 2 && half[i].3 == half[i + 1].3 {
            let edge = if half[i].3 { [a, b] } else { [b, a] };
            inconsistent.add(|| MeshError::InconsistentOrientation {
                triangle1: half[i].2,
                triangle2: half[i + 1].2,
                edge,
            });
        }
        i = j;
    }
    (non_manifold, inconsistent)
}

/// Faces shared by more than two of the tets `good`, first by sorted face.
fn tet_face_problems(tets: &[[u32; 4]], good: &[usize]) -> Acc {
    let mut faces: Vec<[u32; 3]> = Vec::with_capacity(4 * good.len());
    for &t in good {
        let [a, b, c, d] = tets[t];
        for mut f in [[b, c, d], [a, c, d], [a, b, d], [a, b, c]] {
            f.sort_unstable();
            faces.push(f);
        }
    }
    faces.sort_unstable();
    let mut acc = Acc::default();
    let mut i = 0;
    while i < faces.len() {
        let mut j = i + 1;
        while j < faces.len() && faces[j] == faces[i] {
            j += 1;
        }
        if j - i > 2 {
            acc.add(|| MeshError::NonManifoldFace {
                face: faces[i],
                tets: j - i,
            });
        }
        i = j;
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Field;
    use crate::test_meshes::*;
    use proptest::prelude::*;

    fn p(x: f64, y: f64, z: f64) -> Point3<f64> {
        Point3::new(x, y, z)
    }

    fn sphere() -> TriMesh {
        uv_sphere(5, 7, 2.0)
    }

    fn unit_tet() -> TetMesh {
        TetMesh::new(
            vec![
                p(0.0, 0.0, 0.0),
                p(1.0, 0.0, 0.0),
                p(0.0, 1.0, 0.0),
                p(0.0, 0.0, 1.0),
            ],
            vec![[0, 1, 2, 3]],
        )
    }

    fn kinds(problems: &[Problem]) -> Vec<std::mem::Discriminant<MeshError>> {
        problems
            .iter()
            .map(|p| std::mem::discriminant(&p.error))
            .collect()
    }

    #[test]
    fn good_meshes_validate() {
        assert_eq!(sphere().validate(), Ok(()));
        assert_eq!(grid_disk(3, 2).validate(), Ok(()));
        assert_eq!(unit_tet().validate(), Ok(()));
        let mut grid = tet_grid([2, 2, 3], true, [0.0; 3]);
        grid.orient().unwrap();
        assert_eq!(grid.validate(), Ok(()));
        assert!(check_tet_mesh(&grid, &ValidationOptions::default()).is_empty());
    }

    #[test]
    fn empty() {
        assert_eq!(
            TriMesh::default().validate(),
            Err(MeshError::Empty { what: "vertices" })
        );
        let m = TriMesh::new(vec![p(0.0, 0.0, 0.0)], vec![]);
        assert_eq!(m.validate(), Err(MeshError::Empty { what: "triangles" }));
        let problems = check_tri_mesh(&m, &ValidationOptions::default());
        assert_eq!(problems.len(), 1, "{problems:?}");
        let t = TetMesh::new(vec![p(0.0, 0.0, 0.0)], vec![]);
        assert_eq!(t.validate(), Err(MeshError::Empty { what: "tets" }));
    }

    #[test]
    fn index_out_of_range() {
        let mut m = sphere();
        let n = m.num_vertices();
        m.triangles.push([0, 1, n as u32 + 5]);
        m.triangles.push([n as u32, 1, 2]);
        assert_eq!(
            m.validate(),
            Err(MeshError::IndexOutOfRange {
                element: m.num_triangles() - 2,
                index: n as u32 + 5,
                vertex_count: n,
            })
        );
        let problems = check_tri_mesh(&m, &ValidationOptions::default());
        assert_eq!(problems[0].count, 2);
        // The other checks ignore the bad triangles.
        assert_eq!(problems.len(), 1, "{problems:?}");

        let mut t = unit_tet();
        t.tets.push([0, 1, 2, 4]);
        assert!(matches!(
            t.validate(),
            Err(MeshError::IndexOutOfRange {
                element: 1,
                index: 4,
                ..
            })
        ));
    }

    #[test]
    fn repeated_vertex() {
        let mut m = sphere();
        m.triangles.push([3, 4, 3]);
        assert_eq!(
            m.validate(),
            Err(MeshError::RepeatedVertex {
                element: m.num_triangles() - 1,
                index: 3
            })
        );
        let mut t = unit_tet();
        t.tets.push([0, 1, 1, 2]);
        assert_eq!(
            t.validate(),
            Err(MeshError::RepeatedVertex {
                element: 1,
                index: 1
            })
        );
    }

    #[test]
    fn non_finite_coordinate() {
        let mut m = sphere();
        m.positions[4].y = f64::NAN;
        m.positions[6].z = f64::INFINITY;
        assert!(matches!(
            m.validate(),
            Err(MeshError::NonFiniteCoordinate { vertex: 4, .. })
        ));
        assert_eq!(
            check_tri_mesh(&m, &ValidationOptions::default())[0].count,
            2
        );
        let mut t = unit_tet();
        t.positions[3].x = f64::NEG_INFINITY;
        assert!(matches!(
            t.validate(),
            Err(MeshError::NonFiniteCoordinate { vertex: 3, .. })
        ));
    }

    #[test]
    fn overflowing_measures() {
        // Finite coordinates whose volume overflows: one problem, not a
        // degenerate or inverted one.
        let mut t = unit_tet();
        for v in &mut t.positions {
            v.coords *= 1e308;
        }
        let problems = check_tet_mesh(&t, &ValidationOptions::default());
        assert!(
            matches!(
                problems[0].error,
                MeshError::NonFiniteMeasure {
                    what: "volume",
                    element: 0,
                    ..
                }
            ),
            "{problems:?}"
        );
        assert_eq!(problems.len(), 1, "{problems:?}");
        assert!(
            problems[0]
                .error
                .to_string()
                .contains("scale the mesh down")
        );
        // Ten disjoint tets of finite volume (s³/6 = 2e307 each) whose sum
        // overflows.
        let s = 5e102;
        let mut positions = Vec::new();
        let mut tets = Vec::new();
        for k in 0..10u32 {
            let x = 2.0 * s * f64::from(k);
            positions.extend([
                p(x, 0.0, 0.0),
                p(x + s, 0.0, 0.0),
                p(x, s, 0.0),
                p(x, 0.0, s),
            ]);
            tets.push([4 * k, 4 * k + 1, 4 * k + 2, 4 * k + 3]);
        }
        let m = TetMesh::new(positions, tets);
        let opts = ValidationOptions {
            require_single_component: false,
            ..ValidationOptions::default()
        };
        let problems = check_tet_mesh(&m, &opts);
        assert!(
            matches!(
                problems.as_slice(),
                [Problem {
                    error: MeshError::NonFiniteTotalMeasure { what: "volume", .. },
                    count: 1
                }]
            ),
            "{problems:?}"
        );
        // A mesh of ordinary size has neither.
        assert!(check_tet_mesh(&unit_tet(), &ValidationOptions::default()).is_empty());
    }

    #[test]
    fn degenerate_element() {
        // Vertex 3 lies on the segment 0-2: triangle 1 has zero area.
        let m = TriMesh::new(
            vec![
                p(0.0, 0.0, 0.0),
                p(1.0, 0.0, 0.0),
                p(1.0, 1.0, 0.0),
                p(0.5, 0.5, 0.0),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        );
        assert!(matches!(
            m.validate(),
            Err(MeshError::DegenerateElement { element: 1, measure, .. }) if measure == 0.0
        ));
        // A flat tet next to a good one.
        let mut t = unit_tet();
        t.positions.push(p(0.5, 0.5, 0.0));
        t.tets.push([0, 1, 2, 4]);
        assert!(matches!(
            t.validate(),
            Err(MeshError::DegenerateElement { element: 1, .. })
        ));
        // A relative threshold: tiny but not degenerate at 1e-12.
        let mut t = unit_tet();
        t.positions.push(p(0.3, 0.3, -1e-9));
        t.tets.push([0, 2, 1, 4]);
        assert_eq!(t.validate(), Ok(()));
        let strict = ValidationOptions {
            degenerate_rel: 1e-6,
            ..Default::default()
        };
        assert!(matches!(
            check_tet_mesh(&t, &strict)[0].error,
            MeshError::DegenerateElement { element: 1, .. }
        ));
    }

    #[test]
    fn inverted_element() {
        let mut t = unit_tet();
        t.tets[0].swap(0, 1);
        assert!(matches!(
            t.validate(),
            Err(MeshError::InvertedElement { element: 0, volume }) if (volume + 1.0 / 6.0).abs() < 1e-15
        ));
        assert_eq!(t.orient().unwrap(), 1);
        assert_eq!(t.validate(), Ok(()));
    }

    #[test]
    fn unused_vertices() {
        let mut m = sphere();
        m.positions.push(p(9.0, 9.0, 9.0));
        m.positions.push(p(9.0, 9.0, 8.0));
        let n = m.num_vertices();
        assert_eq!(
            m.validate(),
            Err(MeshError::UnusedVertices {
                count: 2,
                first: n - 2
            })
        );
        let opts = ValidationOptions {
            allow_unused_vertices: true,
            ..Default::default()
        };
        assert!(check_tri_mesh(&m, &opts).is_empty());
        let mut t = unit_tet();
        t.positions.insert(0, p(5.0, 5.0, 5.0));
        t.tets[0] = t.tets[0].map(|v| v + 1);
        assert_eq!(
            t.validate(),
            Err(MeshError::UnusedVertices { count: 1, first: 0 })
        );
    }

    #[test]
    fn non_manifold_edge() {
        let m = TriMesh::new(
            vec![
                p(0.0, 0.0, 0.0),
                p(1.0, 0.0, 0.0),
                p(0.5, 1.0, 0.0),
                p(0.5, -1.0, 0.0),
                p(0.5, 0.0, 1.0),
            ],
            vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
        );
        assert_eq!(
            m.validate(),
            Err(MeshError::NonManifoldEdge {
                a: 0,
                b: 1,
                faces: 3
            })
        );
    }

    #[test]
    fn non_manifold_face() {
        let mut t = unit_tet();
        t.positions.push(p(0.0, 0.0, -1.0));
        t.positions.push(p(1.0, 1.0, 1.0));
        t.tets.push([0, 2, 1, 4]);
        t.tets.push([0, 1, 2, 5]);
        assert_eq!(
            t.validate(),
            Err(MeshError::NonManifoldFace {
                face: [0, 1, 2],
                tets: 3
            })
        );
    }

    #[test]
    fn inconsistent_orientation() {
        let mut m = sphere();
        m.triangles[3].swap(0, 1);
        let problems = check_tri_mesh(&m, &ValidationOptions::default());
        assert!(matches!(
            problems[0].error,
            MeshError::InconsistentOrientation { .. }
        ));
        assert_eq!(problems[0].count, 3);
        let m = TriMesh::new(
            vec![
                p(0.0, 0.0, 0.0),
                p(1.0, 0.0, 0.0),
                p(0.5, 1.0, 0.0),
                p(0.5, -1.0, 0.0),
            ],
            vec![[0, 1, 2], [0, 1, 3]],
        );
        assert_eq!(
            m.validate(),
            Err(MeshError::InconsistentOrientation {
                triangle1: 0,
                triangle2: 1,
                edge: [0, 1]
            })
        );
        let lax = ValidationOptions {
            require_consistent_orientation: false,
            ..Default::default()
        };
        assert!(check_tri_mesh(&m, &lax).is_empty());
    }

    #[test]
    fn multiple_components() {
        let a = sphere();
        let mut m = a.clone();
        let off = a.num_vertices() as u32;
        m.positions.extend(
            a.positions
                .iter()
                .map(|q| q + nalgebra::Vector3::new(10.0, 0.0, 0.0)),
        );
        m.triangles
            .extend(a.triangles.iter().map(|t| t.map(|v| v + off)));
        assert_eq!(
            m.validate(),
            Err(MeshError::MultipleComponents { count: 2 })
        );
        let lax = ValidationOptions {
            require_single_component: false,
            ..Default::default()
        };
        assert!(check_tri_mesh(&m, &lax).is_empty());
        let g = merge_tets(
            &tet_grid([1, 1, 1], false, [0.0; 3]),
            &tet_grid([1, 1, 1], false, [5.0, 0.0, 0.0]),
        );
        let problems = check_tet_mesh(&g, &ValidationOptions::default());
        assert!(
            problems
                .iter()
                .any(|p| p.error == MeshError::MultipleComponents { count: 2 })
        );
    }

    #[test]
    fn field_length() {
        let mut m = sphere();
        let n = m.num_vertices();
        m.point_data.insert(Field::scalars("bad", vec![0.0; n - 1]));
        m.cell_data
            .insert(Field::scalars("bad_cells", vec![0.0; 2]));
        assert_eq!(
            m.validate(),
            Err(MeshError::FieldLength {
                name: "bad".into(),
                expected: n,
                found: n - 1
            })
        );
        assert_eq!(
            check_tri_mesh(&m, &ValidationOptions::default())[0].count,
            2
        );
        let mut t = unit_tet();
        t.cell_data.insert(Field::labels("l", vec![1, 2]));
        assert!(matches!(
            t.validate(),
            Err(MeshError::FieldLength {
                expected: 1,
                found: 2,
                ..
            })
        ));
    }

    #[test]
    fn problems_are_ordered_by_severity() {
        let mut m = sphere();
        m.positions.push(p(f64::NAN, 0.0, 0.0)); // non-finite and unused
        m.triangles.push([0, 1, 999]);
        m.triangles.push([5, 5, 6]);
        m.triangles[0].swap(1, 2);
        let problems = check_tri_mesh(&m, &ValidationOptions::default());
        let expect = [
            MeshError::IndexOutOfRange {
                element: 0,
                index: 0,
                vertex_count: 0,
            },
            MeshError::NonFiniteCoordinate {
                vertex: 0,
                x: 0.0,
                y: 0.0,
                z: 0.0,
            },
            MeshError::RepeatedVertex {
                element: 0,
                index: 0,
            },
            MeshError::InconsistentOrientation {
                triangle1: 0,
                triangle2: 0,
                edge: [0, 0],
            },
            MeshError::UnusedVertices { count: 0, first: 0 },
        ];
        assert_eq!(
            kinds(&problems),
            expect
                .iter()
                .map(std::mem::discriminant)
                .collect::<Vec<_>>()
        );
        let s = problems[0].to_string();
        assert!(s.contains("999"), "{s}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        /// Garbage in, problems out: never a panic.
        #[test]
        fn checks_never_panic(
            seed: u64, n in 0usize..8, ntri in 0usize..10, nan in 0usize..3,
            field_len in 0usize..10,
        ) {
            let mut rng = SplitMix(seed);
            let mut positions: Vec<Point3<f64>> =
                (0..n).map(|_| p(rng.sym(1.0), rng.sym(1.0), rng.sym(1.0))).collect();
            for _ in 0..nan.min(n) {
                let i = rng.below(n);
                positions[i].x = if rng.coin(0.5) { f64::NAN } else { f64::INFINITY };
            }
            let idx = |rng: &mut SplitMix| rng.below(n + 2) as u32;
            let tris: Vec<[u32; 3]> =
                (0..ntri).map(|_| [idx(&mut rng), idx(&mut rng), idx(&mut rng)]).collect();
            let tets: Vec<[u32; 4]> = (0..ntri)
                .map(|_| [idx(&mut rng), idx(&mut rng), idx(&mut rng), idx(&mut rng)])
                .collect();
            let mut m = TriMesh::new(positions.clone(), tris);
            m.point_data.insert(Field::scalars("f", vec![0.0; field_len]));
            let mut t = TetMesh::new(positions, tets);
            t.cell_data.insert(Field::scalars("f", vec![0.0; field_len]));
            for opts in [ValidationOptions::default(), ValidationOptions {
                allow_unused_vertices: true,
                require_single_component: false,
                require_consistent_orientation: false,
                degenerate_rel: 0.5,
            }] {
                let pm = check_tri_mesh(&m, &opts);
                let pt = check_tet_mesh(&t, &opts);
                for problems in [&pm, &pt] {
                    prop_assert!(problems.iter().all(|p| p.count >= 1));
                    // At most one problem per kind.
                    let mut k = kinds(problems);
                    k.dedup();
                    prop_assert_eq!(k.len(), problems.len());
                }
                prop_assert_eq!(m.validate().is_ok(), check_tri_mesh(&m, &Default::default()).is_empty());
                let _ = t.validate();
            }
        }
    }
}

//! The rest state of a parameterization: elements, inverse rest edge
//! matrices and normalized rest measures, computed once (ALGORITHMS 1.1).

use crate::ParamError;
use nalgebra::{Matrix2, Matrix3, Point3, Vector3};
use unfold_mesh::geometry::{tet_signed_volume, triangle_area};
use unfold_mesh::{MeshError, TetMesh, TriMesh};

/// Relative threshold below which an element is degenerate:
/// `|measure| < DEGENERATE_REL * mean |measure|` (ALGORITHMS 1.1).
pub const DEGENERATE_REL: f64 = 1e-12;

/// The elements of a parameterization and their rest data.
///
/// - `Tets`: a tet mesh mapped into 3D. `Dm = [z1-z0, z2-z0, z3-z0]`.
/// - `Tris`: a triangle mesh mapped to the plane. Each rest triangle is
///   expressed in its own orthonormal frame (x along `p1-p0`, normal `n`,
///   `y = n × x`), giving a 2x2 `Dm`.
///
/// `J = Ds Dm^-1` with `Ds` the mapped edge matrix.
#[derive(Debug, Clone)]
pub enum RestElements {
    /// Tets with `Dm^-1`.
    Tets {
        /// Vertex indices, positively oriented in the rest state.
        tets: Vec<[u32; 4]>,
        /// `Dm^-1` per tet.
        dm_inv: Vec<Matrix3<f64>>,
    },
    /// Triangles with `Dm^-1` in their local 2D frames.
    Tris {
        /// Vertex indices.
        tris: Vec<[u32; 3]>,
        /// `Dm^-1` per triangle.
        dm_inv: Vec<Matrix2<f64>>,
    },
}

/// The rest mesh of a map: positions, elements with `Dm^-1`, rest measures
/// (volumes or areas) and the weights `V_k = measure_k / sum measure`.
#[derive(Debug, Clone)]
pub struct ParamMesh {
    /// Rest positions (the input shape).
    pub rest: Vec<Point3<f64>>,
    /// Elements and their inverse rest edge matrices.
    pub elements: RestElements,
    /// Rest volume (tets) or area (triangles) per element.
    pub measure: Vec<f64>,
    /// `measure_k / sum measure` (sums to 1).
    pub weight: Vec<f64>,
}

impl ParamMesh {
    /// The triangles of a triangle mesh, for a `piece` that needs them.
    ///
    /// # Errors
    /// [`ParamError::WrongElements`] naming `piece` for a tet mesh.
    pub fn triangles(&self, piece: &'static str) -> Result<&[[u32; 3]], ParamError> {
        match &self.elements {
            RestElements::Tris { tris, .. } => Ok(tris),
            RestElements::Tets { .. } => Err(ParamError::WrongElements {
                piece,
                needs: crate::error::Elements::Triangles,
                found: crate::error::Elements::Tets,
                hint: "",
            }),
        }
    }

    /// Rest data of a tet mesh mapped into 3D. Every tet must be positively
    /// oriented (see `TetMesh::orient`) and non-degenerate.
    pub fn from_tets(mesh: &TetMesh) -> Result<Self, ParamError> {
        unfold_mesh::geometry::check_finite(&mesh.positions)?;
        unfold_mesh::geometry::check_indices(mesh.positions.len(), &mesh.tets)?;
        if mesh.tets.is_empty() {
            return Err(MeshError::Empty { what: "tets" }.into());
        }
        let vols: Vec<f64> = (0..mesh.num_tets())
            .map(|t| {
                let [a, b, c, d] = mesh.tet_points(t);
                tet_signed_volume(&a, &b, &c, &d)
            })
            .collect();
        let mean = vols.iter().map(|v| v.abs()).sum::<f64>() / vols.len() as f64;
        let threshold = DEGENERATE_REL * mean;
        let mut dm_inv = Vec::with_capacity(vols.len());
        for (t, &v) in vols.iter().enumerate() {
            if v.abs() <= threshold || mean == 0.0 {
                return Err(MeshError::DegenerateElement {
                    element: t,
                    measure: v,
                    threshold,
                }
                .into());
            }
            if v < 0.0 {
                return Err(MeshError::InvertedElement {
                    element: t,
                    volume: v,
                }
                .into());
            }
            let [a, b, c, d] = mesh.tet_points(t);
            let dm = Matrix3::from_columns(&[b - a, c - a, d - a]);
            let inv = dm.try_inverse().ok_or(MeshError::DegenerateElement {
                element: t,
                measure: v,
                threshold,
            })?;
            dm_inv.push(inv);
        }
        let total: f64 = vols.iter().sum();
        Ok(ParamMesh {
            rest: mesh.positions.clone(),
            elements: RestElements::Tets {
                tets: mesh.tets.clone(),
                dm_inv,
            },
            weight: vols.iter().map(|v| v / total).collect(),
            measure: vols,
        })
    }

    /// Rest data of a triangle mesh mapped to the plane (every triangle
    /// non-degenerate).
    pub fn from_triangles(mesh: &TriMesh) -> Result<Self, ParamError> {
        unfold_mesh::geometry::check_finite(&mesh.positions)?;
        unfold_mesh::geometry::check_indices(mesh.positions.len(), &mesh.triangles)?;
        if mesh.triangles.is_empty() {
            return Err(MeshError::Empty { what: "triangles" }.into());
        }
        let areas: Vec<f64> = (0..mesh.num_triangles())
            .map(|t| {
                let [a, b, c] = mesh.triangle_points(t);
                triangle_area(&a, &b, &c)
            })
            .collect();
        let mean = areas.iter().sum::<f64>() / areas.len() as f64;
        let threshold = DEGENERATE_REL * mean;
        let mut dm_inv = Vec::with_capacity(areas.len());
        for (t, &area) in areas.iter().enumerate() {
            let degenerate = MeshError::DegenerateElement {
                element: t,
                measure: area,
                threshold,
            };
            if area <= threshold || mean == 0.0 {
                return Err(degenerate.into());
            }
            let [a, b, c] = mesh.triangle_points(t);
            let dm = local_frame_edges(&a, &b, &c);
            dm_inv.push(dm.try_inverse().ok_or(degenerate)?);
        }
        let total: f64 = areas.iter().sum();
        Ok(ParamMesh {
            rest: mesh.positions.clone(),
            elements: RestElements::Tris {
                tris: mesh.triangles.clone(),
                dm_inv,
            },
            weight: areas.iter().map(|a| a / total).collect(),
            measure: areas,
        })
    }

    /// Dimension of the mapped positions: 3 for tets, 2 for triangles.
    pub fn dim(&self) -> usize {
        match self.elements {
            RestElements::Tets { .. } => 3,
            RestElements::Tris { .. } => 2,
        }
    }

    /// Number of vertices.
    pub fn num_vertices(&self) -> usize {
        self.rest.len()
    }

    /// Number of elements.
    pub fn num_elements(&self) -> usize {
        self.measure.len()
    }

    /// Vertex indices of element `e` (3 or 4 of them).
    pub fn element(&self, e: usize) -> &[u32] {
        match &self.elements {
            RestElements::Tets { tets, .. } => &tets[e],
            RestElements::Tris { tris, .. } => &tris[e],
        }
    }

    /// The same elements at `c` times the size (`c > 0`): rest positions
    /// times `c`, `Dm^-1 / c`, measures times `c^d`, the weights unchanged.
    /// A map's `J` against the scaled rest is `J / c`.
    pub fn scaled(&self, c: f64) -> ParamMesh {
        let cd = c.powi(self.dim() as i32);
        ParamMesh {
            rest: self
                .rest
                .iter()
                .map(|p| Point3::from(p.coords * c))
                .collect(),
            elements: match &self.elements {
                RestElements::Tets { tets, dm_inv } => RestElements::Tets {
                    tets: tets.clone(),
                    dm_inv: dm_inv.iter().map(|m| m / c).collect(),
                },
                RestElements::Tris { tris, dm_inv } => RestElements::Tris {
                    tris: tris.clone(),
                    dm_inv: dm_inv.iter().map(|m| m / c).collect(),
                },
            },
            measure: self.measure.iter().map(|m| m * cd).collect(),
            weight: self.weight.clone(),
        }
    }

    /// The identity map: rest positions (tets) as a flat `n * 3` vector.
    /// For triangles there is no identity into the plane; use an
    /// initializer.
    pub fn rest_flat(&self) -> Vec<f64> {
        self.rest.iter().flat_map(|p| [p.x, p.y, p.z]).collect()
    }
}

/// The rest edges `[p1-p0, p2-p0]` of a 3D triangle expressed in its own
/// orthonormal frame (x along `p1-p0`, y in the plane, ccw): a 2x2 matrix
/// `[[|e1|, e2·x], [0, e2·y]]` with positive determinant (twice the area).
pub fn local_frame_edges(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> Matrix2<f64> {
    let e1: Vector3<f64> = b - a;
    let e2: Vector3<f64> = c - a;
    let l1 = e1.norm();
    let x = if l1 > 0.0 { e1 / l1 } else { Vector3::x() };
    let n = e1.cross(&e2);
    let y = n.cross(&e1);
    let ly = y.norm();
    let y = if ly > 0.0 { y / ly } else { Vector3::y() };
    Matrix2::new(l1, e2.dot(&x), 0.0, e2.dot(&y))
}

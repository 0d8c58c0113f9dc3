//! A template the library does not have, written in user code: pull the
//! placenta slab's maternal side onto a *cylinder* (a uterine wall that is
//! curved in one direction only) instead of a plane.
//!
//! The synthetic slab is a shallow bowl: its maternal face lies on a sphere
//! around the bowl's centre `(0, 0, bend_radius)`. The cylinder's axis is the
//! line through that centre along y, and its radius `r` is the one template
//! parameter, fitted together with the map:
//!
//! ```text
//! d(x) = sqrt((x1 - a1)^2 + (x3 - a3)^2)      distance to the axis
//! T    = (d - r)^2                            maternal vertices, 0 elsewhere
//! ```
//!
//! So the bowl keeps its curvature along x and is straightened along y.
//!
//! ```sh
//! cargo run --release --example custom_template
//! ```

use unfold::io::{WriteOptions, write_mesh};
use unfold::mesh::geometry::vertex_areas;
use unfold::mesh::shapes::{PlacentaParams, SIDE_MATERNAL, placenta_slab};
use unfold::mesh::topology::tet_boundary;
use unfold::mesh::{CellMesh, Field, nalgebra::Point3};
use unfold::param::energy::SymmetricDirichlet;
use unfold::param::metrics::{
    Summary, dirichlet_excess_percent, inverted_count, log2_det_j, min_det_j,
    template_matching_error,
};
use unfold::param::{Executor, Objective, ParamMesh, ProjectedNewton, Template, TemplateTerm};

/// `T = (d - r)^2` on the vertices labelled `label`, `d` the distance to an
/// axis parallel to y through `(axis_x, *, axis_z)`; `theta = [r]`.
#[derive(Debug)]
struct Cylinder {
    axis_x: f64,
    axis_z: f64,
    label: u8,
}

impl Cylinder {
    /// `(d, n)`: the distance to the axis and the unit normal pointing away
    /// from it (in the x-z plane).
    fn radial(&self, x: &[f64]) -> (f64, [f64; 3]) {
        let (u, w) = (x[0] - self.axis_x, x[2] - self.axis_z);
        let d = u.hypot(w);
        (d, [u / d, 0.0, w / d])
    }
}

impl Template for Cylinder {
    fn name(&self) -> &'static str {
        "cylinder"
    }

    fn parameter_names(&self) -> Vec<&'static str> {
        vec!["r"]
    }

    fn value(&self, _v: usize, label: u8, x: &[f64], theta: &[f64]) -> f64 {
        if label != self.label {
            return 0.0;
        }
        (self.radial(x).0 - theta[0]).powi(2)
    }

    /// `dT/dx = 2 (d - r) n`.
    fn gradient(&self, _v: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        if label == self.label {
            let (d, n) = self.radial(x);
            for i in 0..3 {
                out[i] = 2.0 * (d - theta[0]) * n[i];
            }
        }
    }

    /// `d2T/dx2 = 2 n n^T + 2 (d - r)/d (P - n n^T)`, `P` the projection onto
    /// the x-z plane. Its eigenvalues are 2 (along `n`), `2 (d - r)/d` (the
    /// tangent in the x-z plane) and 0 (along the axis): projecting to PSD
    /// is clamping the middle one at 0.
    fn hessian(&self, _v: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        if label != self.label {
            return;
        }
        let (d, n) = self.radial(x);
        let t = 2.0 * ((d - theta[0]) / d).max(0.0);
        let p = [1.0, 0.0, 1.0];
        for i in 0..3 {
            for j in 0..3 {
                let p_ij = if i == j { p[i] } else { 0.0 };
                out[3 * i + j] = 2.0 * n[i] * n[j] + t * (p_ij - n[i] * n[j]);
            }
        }
    }

    /// `dT/dr = -2 (d - r)`. (`theta_hessian` and `mixed_hessian` are left
    /// to the trait's numerical defaults.)
    fn theta_gradient(&self, _v: usize, label: u8, x: &[f64], theta: &[f64], out: &mut [f64]) {
        out[0] = if label == self.label {
            -2.0 * (self.radial(x).0 - theta[0])
        } else {
            0.0
        };
    }

    /// For fixed positions the best radius is the weighted mean distance:
    /// `r = sum w_m d_m / sum w_m`.
    fn update_theta(
        &self,
        labels: &[u8],
        xs: &[f64],
        dim: usize,
        weights: &[f64],
        theta: &mut [f64],
    ) -> bool {
        let (mut num, mut den) = (0.0, 0.0);
        for (m, (&label, &w)) in labels.iter().zip(weights).enumerate() {
            if label == self.label && w > 0.0 {
                num += w * self.radial(&xs[m * dim..m * dim + dim]).0;
                den += w;
            }
        }
        if den > 0.0 {
            theta[0] = num / den;
        }
        den > 0.0
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // The shape: 7,200 tets; labels are its sides, weights the normalized
    // boundary vertex areas.
    let params = PlacentaParams {
        cells_radial: 10,
        cells_through: 4,
        ..PlacentaParams::default()
    };
    let shape = placenta_slab(&params)?;
    let boundary = tet_boundary(&shape.mesh)?;
    let areas = vertex_areas(&boundary.surface);
    let total: f64 = areas.iter().sum();
    let mut weights = vec![0.0; shape.mesh.num_vertices()];
    for (i, &v) in boundary.to_volume.iter().enumerate() {
        weights[v as usize] = areas[i] / total;
    }
    let mesh = ParamMesh::from_tets(&shape.mesh)?;

    // The new template, plugged into the stock objective and solver.
    let cylinder = Cylinder {
        axis_x: 0.0,
        axis_z: params.bend_radius,
        label: SIDE_MATERNAL,
    };
    let term = TemplateTerm {
        template: &cylinder,
        labels: &shape.side,
        weights: &weights,
    };
    let mut objective = Objective::new(&mesh, &SymmetricDirichlet, 1.0, Some(term), &[])?;
    let mut x = mesh.rest_flat();
    let mut theta = [params.bend_radius];
    let spread = |x: &[f64]| {
        let d: Vec<f64> = (0..mesh.num_vertices())
            .filter(|&v| shape.side[v] == SIDE_MATERNAL)
            .map(|v| cylinder.radial(&x[3 * v..3 * v + 3]).0)
            .collect();
        let (lo, hi) = d.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &d| {
            (lo.min(d), hi.max(d))
        });
        hi - lo
    };
    println!(
        "{} tets; maternal distance to the axis varies by {:.2} mm before",
        mesh.num_elements(),
        spread(&x)
    );

    let report =
        Executor::new(&ProjectedNewton::default()).run(&mut objective, &mut x, &mut theta)?;
    println!(
        "newton: {:?} after {} iterations, {:.2} s, |grad| {:.1e}",
        report.reason, report.iterations, report.seconds, report.grad_norm
    );
    println!("radius r = {:.2} mm", theta[0]);
    println!(
        "template error sqrt(sum w T) = {:.4} mm; maternal distance varies by {:.3} mm after",
        template_matching_error(&cylinder, &shape.side, &x, 3, &weights, &theta),
        spread(&x)
    );
    let log2_det = Summary::of(&log2_det_j(&mesh, &x)).ok_or("no tets")?;
    println!(
        "distortion: Dirichlet excess {:.3} %, log2 det J in [{:.3}, {:.3}] (std {:.3}), \
         min det J {:.3}, {} inverted tets",
        dirichlet_excess_percent(&mesh, &x),
        log2_det.min,
        log2_det.max,
        log2_det.std,
        min_det_j(&mesh, &x),
        inverted_count(&mesh, &x)
    );

    // The mapped slab, with the per-tet volume change, as VTK XML.
    let mut mapped = shape.mesh.clone();
    mapped.positions = x
        .chunks_exact(3)
        .map(|p| Point3::new(p[0], p[1], p[2]))
        .collect();
    mapped
        .cell_data
        .insert(Field::scalars("log2_det_j", log2_det_j(&mesh, &x)));
    let path = std::env::temp_dir().join("unfold_custom_template.vtu");
    write_mesh(&path, &CellMesh::from(&mapped), &WriteOptions::default())?;
    println!("wrote {}", path.display());
    Ok(())
}

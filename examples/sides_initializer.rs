//! A new initializer, plugged into the whole placenta pipeline: instead of
//! the principal axes, the rest positions are turned so that the line from
//! the maternal side's centroid to the fetal side's points up (+z),
//!
//! ```text
//! u = (c_F - c_M) / |c_F - c_M|,   x_i = Q (z_i - c),   Q u = e_z
//! ```
//!
//! with `c_F`, `c_M` the boundary-weighted centroids of the two sides (the
//! labels and weights the pipeline hands every initializer) and `c` the
//! vertex centroid; `Q` is the smallest rotation taking `u` to `e_z` (a
//! proper rotation: no tet inverts).
//! Run with `cargo run --release --example sides_initializer`.

use unfold::mesh::nalgebra::{Rotation3, Vector3};
use unfold::mesh::shapes::{PlacentaParams, placenta_slab, side};
use unfold::organs::{Quiet, placenta::Pipeline, placenta::Report};
use unfold::param::{Constraints, InitialMap, Initializer, ParamError, ParamMesh};

/// The fetal side up, nothing else assumed.
#[derive(Debug)]
pub struct SidesUp;

impl Initializer for SidesUp {
    fn name(&self) -> &'static str {
        "sides-up"
    }
    fn initialize(&self, mesh: &ParamMesh, c: &Constraints<'_>) -> Result<InitialMap, ParamError> {
        let n = mesh.num_vertices();
        if c.labels.len() != n || c.weights.len() != n {
            let found = c.labels.len().min(c.weights.len());
            let what = "side labels and weights";
            return Err(ParamError::Length {
                what,
                expected: n,
                found,
            });
        }
        let centroid = |label: u8| {
            let (mut sum, mut w) = (Vector3::zeros(), 0.0);
            for ((p, &l), &wi) in mesh.rest.iter().zip(c.labels).zip(c.weights) {
                if l == label {
                    (sum, w) = (sum + wi * p.coords, w + wi);
                }
            }
            sum / w
        };
        let up = (centroid(side::FETAL) - centroid(side::MATERNAL)).normalize();
        let q = Rotation3::rotation_between(&up, &Vector3::z()).unwrap_or_else(|| {
            Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
        });
        let mid = mesh.rest.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n as f64;
        let x = mesh
            .rest
            .iter()
            .flat_map(|p| (q * (p.coords - mid)).data.0[0])
            .collect();
        Ok(InitialMap::new(x))
    }
}

/// Flattens the synthetic placenta from this start.
pub fn run() -> Result<Report, Box<dyn std::error::Error>> {
    let shape = PlacentaParams {
        cells_radial: 8,
        cells_through: 3,
        ..PlacentaParams::default()
    };
    let slab = placenta_slab(&shape)?;
    Ok(Pipeline::new()
        .initializer(SidesUp)
        .run(&slab.mesh, &[], &mut Quiet)?
        .report)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    println!("{}", serde_json::to_string_pretty(&run()?)?);
    Ok(())
}

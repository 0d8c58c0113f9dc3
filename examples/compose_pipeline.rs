//! Composing the placenta pipeline from its steps, in code.
//!
//! 1. Only the boundary parcellation of a synthetic placenta (fetal side,
//!    maternal side, margin), compared with the generator's ground truth.
//! 2. Then the flattening onto an *ellipsoid* with `lambda = 0.5` instead of
//!    the default planes with `lambda = 1`, assembled from the public steps
//!    (alignment, initial radii, optimization, evaluation), and checked
//!    against the one-call [`flatten`].
//!
//! Run with `cargo run --release --example compose_pipeline`.

use unfold::mesh::shapes::{PlacentaParams, Pose, placenta_slab};
use unfold::organs::placenta::align::align;
use unfold::organs::placenta::estimate::estimate;
use unfold::organs::placenta::parcellation::{ParcellationConfig, parcellate};
use unfold::organs::placenta::{
    Config, Problem, Quiet, TemplateKind, boundary_weights, evaluate, flatten, initial_theta,
    optimize, prepare_mesh, template_of,
};
use unfold::param::ParamMesh;
use unfold::param::template::{LABEL_FETAL, LABEL_MARGIN, LABEL_MATERNAL};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let shape = placenta_slab(&PlacentaParams {
        cells_radial: 10,
        pose: Pose::new([20.0, -35.0, 60.0], [12.0, -40.0, 90.0]),
        ..PlacentaParams::default()
    })?;
    let mesh = prepare_mesh(&shape.mesh)?.mesh;
    println!(
        "slab: {} vertices, {} tets",
        mesh.num_vertices(),
        mesh.num_tets()
    );

    // 1. The parcellation alone, with a narrower margin than the default.
    let pconfig = ParcellationConfig {
        margin_mm: 9.0,
        ..ParcellationConfig::default()
    };
    let parcellation = parcellate(&mesh, &pconfig)?;
    let s = &parcellation.summary;
    let count = |l: u8| parcellation.labels.iter().filter(|&&x| x == l).count();
    let agree = (0..mesh.num_vertices())
        .filter(|&v| {
            let l = parcellation.labels[v];
            (l == LABEL_FETAL || l == LABEL_MATERNAL) && l == shape.side[v]
        })
        .count();
    println!(
        "parcellation: {} fetal, {} maternal, {} margin (r = {} mm, {:.0} % of the area); \
         {agree} of {} side labels match the generator; Fiedler value {:.2e}",
        count(LABEL_FETAL),
        count(LABEL_MATERNAL),
        count(LABEL_MARGIN),
        s.margin_radius_mm,
        100.0 * s.margin_area_fraction,
        s.fetal + s.maternal,
        s.fiedler_value
    );

    // 2. An ellipsoid with lambda = 0.5, step by step (default margin).
    let config = Config {
        template: TemplateKind::Ellipsoid,
        lambda: 0.5,
        ..Config::default()
    };
    let parcellation = parcellate(&mesh, &config.parcellation)?;
    let labels = parcellation.labels.clone();
    let weights = boundary_weights(&parcellation);
    let alignment = align(&mesh.positions, &labels, &weights)?;
    let on_boundary = {
        let mut b = vec![false; mesh.num_vertices()];
        for &v in &parcellation.boundary.to_volume {
            b[v as usize] = true;
        }
        b
    };
    let estimates = estimate(&mesh, &parcellation.boundary.surface, &on_boundary)?;
    let x0: Vec<f64> = mesh
        .positions
        .iter()
        .flat_map(|p| {
            let q = alignment.apply(p);
            [q.x, q.y, q.z]
        })
        .collect();
    let rest = ParamMesh::from_tets(&mesh)?;
    let theta0 = initial_theta(config.template, &estimates);
    let problem = Problem {
        mesh: &rest,
        labels: &labels,
        weights: &weights,
    };
    let result = optimize(&problem, &config, x0, theta0, &mut Quiet)?;
    let template = template_of(config.template);
    let eval = evaluate(
        &rest,
        &parcellation,
        template.as_ref(),
        &weights,
        &result.x,
        &result.theta,
    );
    let stage = &result.stages[0];
    println!(
        "ellipsoid, lambda 0.5: radii {:?} mm (from {:?}), {} Newton iterations, converged {}, \
         template error {:.3} mm, Dirichlet excess {:.2} %, min det J {:.3}, {} inverted",
        stage.theta,
        stage.theta_initial,
        stage.solve.iterations,
        stage.solve.converged,
        eval.template_error_mm,
        eval.dirichlet_excess_percent,
        eval.min_det_j,
        eval.inverted_tets
    );

    // The same through the one-call pipeline.
    let out = flatten(&shape.mesh, &config)?;
    let rel = (out.report.objective - stage.solve.value).abs() / stage.solve.value;
    println!(
        "flatten() with the same config: objective {:.6} (steps: {:.6}, relative difference {rel:.1e})",
        out.report.objective, stage.solve.value
    );
    if rel > 1e-9 {
        return Err("the composed pipeline and flatten() disagree".into());
    }
    Ok(())
}

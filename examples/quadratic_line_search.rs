//! A new line search, plugged into the whole placenta pipeline: Armijo
//! backtracking whose next trial is the minimizer of the quadratic through
//! `phi(0)`, `phi'(0)` and the rejected trial (Nocedal and Wright 2006,
//! section 3.5), kept within `[0.1 a, 0.5 a]`:
//!
//! ```text
//! a+ = -phi'(0) a^2 / (2 (phi(a) - phi(0) - phi'(0) a))
//! ```
//!
//! Like every line search it starts below the first flip (`0.9 a_max`) and
//! only shrinks, so every accepted step is flip-free.
//! Run with `cargo run --release --example quadratic_line_search`.

use unfold::mesh::shapes::{PlacentaParams, placenta_slab};
use unfold::organs::{PipelineObserver, placenta::Pipeline, placenta::Report};
use unfold::param::{Iteration, LineSearch, LineSearchResult};

/// Armijo backtracking by quadratic interpolation.
#[derive(Debug)]
pub struct Quadratic {
    /// The Armijo constant.
    pub c: f64,
}

impl LineSearch for Quadratic {
    fn name(&self) -> &'static str {
        "quadratic-backtracking"
    }
    fn search(
        &self,
        phi: &mut dyn FnMut(f64) -> f64,
        f0: f64,
        slope: f64,
        a_max: f64,
        a_init: f64,
    ) -> LineSearchResult {
        let mut a = a_init.min(0.9 * a_max);
        let mut evaluations = 0;
        while slope < 0.0 && a.is_finite() && a > 0.0 && evaluations < 60 {
            let v = phi(a);
            evaluations += 1;
            if v.is_finite() && v < f0 && v - f0 <= self.c * a * slope {
                return LineSearchResult::accepted(a, v, evaluations);
            }
            let q = -slope * a * a / (2.0 * (v - f0 - slope * a));
            a = q.max(0.1 * a).min(0.5 * a); // a NaN q gives 0.1 a
        }
        LineSearchResult::rejected(f0, evaluations)
    }
}

/// The objective at every iteration.
#[derive(Default)]
pub struct Values(pub Vec<f64>);

impl PipelineObserver for Values {
    fn iteration(&mut self, it: &Iteration) {
        self.0.push(it.value);
    }
}

/// Flattens the synthetic placenta with this line search.
pub fn run() -> Result<(Report, Values), Box<dyn std::error::Error>> {
    let shape = PlacentaParams {
        cells_radial: 8,
        cells_through: 3,
        ..PlacentaParams::default()
    };
    let (slab, mut values) = (placenta_slab(&shape)?, Values::default());
    let pipeline = Pipeline::new().line_search(Quadratic { c: 1e-4 });
    Ok((pipeline.run(&slab.mesh, &[], &mut values)?.report, values))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (report, values) = run()?;
    println!("{}", serde_json::to_string_pretty(&report)?);
    println!("objective: {:?}", values.0);
    Ok(())
}

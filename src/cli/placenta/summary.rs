//! The summary of a placenta run on stdout.

use crate::app::names::stop_name;
use crate::organs::placenta::Report;
use std::fmt;
use std::path::PathBuf;

/// What a run produced, for the summary on stdout.
#[derive(Debug, Clone)]
pub(crate) struct Summary {
    /// The mesh's name.
    pub label: String,
    /// The library's report.
    pub report: Report,
    /// Every file written, in order.
    pub written: Vec<PathBuf>,
}

/// `name value` pairs of template parameters, mm.
fn params(theta: &std::collections::BTreeMap<std::borrow::Cow<'static, str>, f64>) -> String {
    theta
        .iter()
        .map(|(k, v)| format!("{k} {v:.2}"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn plural(n: usize, one: &str) -> String {
    if n == 1 {
        format!("{n} {one}")
    } else {
        format!("{n} {one}s")
    }
}

impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = &self.report;
        let status = if r.converged {
            "converged".to_string()
        } else {
            format!("NOT converged ({})", stop_name(r.stop_reason))
        };
        writeln!(
            f,
            "{}: {} tets, {} vertices -> {} template ({}): {status} in {}, {:.2} s",
            self.label,
            r.input.tets,
            r.input.vertices,
            r.template,
            r.solver,
            plural(r.iterations, "iteration"),
            r.seconds
        )?;
        if r.input.reoriented_tets > 0 {
            writeln!(
                f,
                "  reoriented {} (negatively oriented in the input)",
                plural(r.input.reoriented_tets, "tet")
            )?;
        }
        writeln!(
            f,
            "  template error {:.3} mm ({:.3} voxels of {} mm), Dirichlet excess {:.2} %",
            r.template_error_mm, r.template_error_voxels, r.voxel_mm, r.dirichlet_excess_percent
        )?;
        writeln!(
            f,
            "  min det J {:.4}, {}",
            r.min_det_j,
            plural(r.inverted_tets, "inverted tet")
        )?;
        writeln!(
            f,
            "  {} mm (initial {} mm)",
            params(&r.theta),
            params(&r.theta_initial)
        )?;
        writeln!(
            f,
            "  boundary vertices: {} fetal, {} maternal, {} margin",
            r.boundary.fetal, r.boundary.maternal, r.boundary.margin
        )?;
        for i in &r.images {
            writeln!(
                f,
                "  {} -> {}: {} voxels inside the mesh, {} sampled, {} outside the image",
                i.input.as_deref().unwrap_or(&i.name),
                i.output.as_deref().unwrap_or("-"),
                i.inside_mesh,
                i.sampled,
                i.outside_image
            )?;
        }
        for (k, p) in self.written.iter().enumerate() {
            if k + 1 == self.written.len() {
                write!(f, "wrote {}", p.display())?;
            } else {
                writeln!(f, "wrote {}", p.display())?;
            }
        }
        Ok(())
    }
}

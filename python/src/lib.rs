//! `unfold._native`: the Rust side of the `unfold` Python package
//! (distribution `unfold-organs`). numpy in, numpy out; every function runs
//! the library the `unfold` command line runs, with the GIL released during
//! the Rust work, and raises `unfold.UnfoldError` with the command line's
//! one-line message on any failure.
//!
//! The Python wrappers in `python/unfold/` turn the tuples returned here
//! into `Mesh` and result objects and coerce arguments
//! (`numpy.asarray`) before they get here.

mod arrays;
mod batch;
mod compare;
mod deform;
mod inputs;
mod mitral;
mod placenta;
mod progress;
mod shapes;
mod template;
mod tet_mesh;
mod ventricle;
mod ventricle_inverse;

use pyo3::prelude::*;

/// The allocator of the `unfold` command (see `src/main.rs`), for the
/// Rust allocations of this module: the pipelines run as fast from Python
/// as from the command line (`benches/python_overhead.py`).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

pyo3::create_exception!(
    unfold,
    UnfoldError,
    pyo3::exceptions::PyValueError,
    "An input unfold cannot use, or a file it cannot read or write; the message is the \
     command line's one-line message (what is wrong and what to do)."
);

/// An [`UnfoldError`] with `e`'s one-line message.
pub(crate) fn error(e: impl std::fmt::Display) -> PyErr {
    UnfoldError::new_err(e.to_string())
}

/// An organ pipeline's failure on `inputs` (each named, with its points)
/// as an [`UnfoldError`]: `e`'s message, and when an input is smaller than
/// the `organ` (`unfold::app::run::units::OrganSize`), the note the command
/// line adds that unfold reads millimetres, with the unit the points are
/// likely in.
pub(crate) fn input_error(
    e: impl std::fmt::Display,
    inputs: &[(&str, &[unfold::mesh::nalgebra::Point3<f64>])],
    organ: unfold::app::run::units::OrganSize,
) -> PyErr {
    use unfold::app::run::units::note;
    let small = inputs.iter().find_map(|(name, points)| {
        let side = organ.too_small(points)?;
        let unit = organ.likely_unit(side);
        let fix = format!("multiply the points by {}", unit.millimetres());
        Some(note(name, side, unit, &fix))
    });
    match small {
        Some(note) => UnfoldError::new_err(format!("{e}; {note}")),
        None => error(e),
    }
}

/// The native module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("UnfoldError", m.py().get_type::<UnfoldError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(arrays::read_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::write_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(placenta::placenta, m)?)?;
    m.add_function(wrap_pyfunction!(shapes::placenta_slab, m)?)?;
    m.add_function(wrap_pyfunction!(template::check_template, m)?)?;
    m.add_class::<batch::Plan>()?;
    for f in [
        wrap_pyfunction!(batch::main, m)?,
        wrap_pyfunction!(batch::plan, m)?,
        wrap_pyfunction!(batch::prepare_output, m)?,
        wrap_pyfunction!(batch::recorded_hash, m)?,
        wrap_pyfunction!(batch::run_hash, m)?,
        wrap_pyfunction!(batch::run_subject, m)?,
        wrap_pyfunction!(batch::place_subject, m)?,
        wrap_pyfunction!(batch::finish, m)?,
        wrap_pyfunction!(batch::cohort, m)?,
        wrap_pyfunction!(compare::compare, m)?,
    ] {
        m.add_function(f)?;
    }
    m.add_function(wrap_pyfunction!(tet_mesh::tet_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(ventricle::ventricle, m)?)?;
    m.add_function(wrap_pyfunction!(ventricle_inverse::ventricle_inverse, m)?)?;
    m.add_function(wrap_pyfunction!(mitral::mitral, m)?)?;
    m.add_function(wrap_pyfunction!(mitral::mitral_seg, m)?)?;
    m.add_function(wrap_pyfunction!(deform::deform, m)?)?;
    m.add_function(wrap_pyfunction!(shapes::ventricle_cup_shape, m)?)?;
    m.add_function(wrap_pyfunction!(shapes::mitral_valve_shape, m)?)?;
    Ok(())
}

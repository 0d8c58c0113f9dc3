//! Runs every example that plugs a new piece into a whole pipeline and
//! checks what it reports: converged, flip-free, the new piece in use. The
//! examples are included as modules, so they are compiled against the
//! public API exactly as a user's crate would be.

#[allow(dead_code)]
#[path = "../examples/amips_mitral.rs"]
mod amips_mitral;
#[allow(dead_code)]
#[path = "../examples/cylinder_template.rs"]
mod cylinder_template;
#[allow(dead_code)]
#[path = "../examples/quadratic_line_search.rs"]
mod quadratic_line_search;
#[allow(dead_code)]
#[path = "../examples/sides_initializer.rs"]
mod sides_initializer;

use unfold::param::template::check::{energy_derivatives, template_derivatives};

#[test]
fn a_new_placenta_template_flattens_flip_free() {
    let r = cylinder_template::run().unwrap();
    assert_eq!(r.template, "cylinders");
    assert!(r.converged, "{:?}", r.stop_reason);
    assert_eq!(r.inverted_tets, 0);
    assert!(r.min_det_j > 0.0);
    assert!(r.theta["h"] > 0.0);
    // On a slab bent on a sphere of 150 mm, cylinders of 150 mm fit well.
    assert!(r.template_error_mm < 1.5, "{}", r.template_error_mm);
    for (label, x) in [
        (1, [3.0, 4.0, 12.0]),
        (2, [-5.0, 1.0, -9.0]),
        (1, [0.0, 2.0, -1.0]),
    ] {
        let t = &cylinder_template::Cylinders;
        template_derivatives(t, 0, label, &x, &[8.0], 1e-6).unwrap();
    }
}

#[test]
fn a_new_energy_relaxes_the_mitral_leaflets_flip_free() {
    let r = amips_mitral::run().unwrap();
    assert_eq!(r.pieces.energy, "conformal-amips");
    assert_eq!(r.flipped_triangles, 0);
    assert!(
        r.relax_reports
            .iter()
            .all(|x| x.converged && x.flipped_triangles == 0)
    );
    // A conformal energy lowers the angle distortion of the layout.
    assert!(r.distortion.r#final.angle < r.distortion.initial.angle);
    for s in [[1.3, 0.7], [2.0, 1.9], [1.0, 1.0]] {
        energy_derivatives(&amips_mitral::Amips, &s, 1e-6).unwrap();
    }
}

#[test]
fn a_new_initializer_starts_the_placenta_pipeline() {
    let r = sides_initializer::run().unwrap();
    assert_eq!(r.pieces.initializer, "sides-up");
    assert!(r.converged, "{:?}", r.stop_reason);
    assert_eq!(r.inverted_tets, 0);
    assert!(r.template_error_mm < 1.5, "{}", r.template_error_mm);
}

#[test]
fn a_new_line_search_drives_the_placenta_pipeline() {
    let (r, values) = quadratic_line_search::run().unwrap();
    assert_eq!(r.pieces.line_search, "quadratic-backtracking");
    assert!(r.converged, "{:?}", r.stop_reason);
    assert_eq!(r.inverted_tets, 0);
    assert!(values.0.len() >= 2);
    assert!(values.0.windows(2).all(|w| w[1] <= w[0]), "{:?}", values.0);
}

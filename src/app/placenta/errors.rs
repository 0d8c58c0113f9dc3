//! The placenta pipeline's errors as the user reads them: each attributed
//! to the input it is about (the mesh or an image) and, where the
//! library's message speaks to programmers, reworded to say what to do.
//! `unfold placenta` and Python's `unfold.placenta` both print these.

use crate::app::AppError;
use crate::io::Frame;
use crate::mesh::MeshError;
use crate::organs::OrganError;
use crate::organs::placenta::{PlacentaError, PullbackError};

/// A pipeline error about the input `path` (the mesh, or an image),
/// reworded where the library's message speaks to programmers (several
/// connected components).
pub fn organ(path: &str, source: impl Into<OrganError>) -> AppError {
    let source = source.into();
    if let OrganError::Mesh(MeshError::MultipleComponents { count }) = source {
        return AppError::Usage(format!(
            "{path}: the mesh has {count} connected components; the placenta pipeline needs \
             one (`unfold repair {path} -o OUT --largest-component` keeps the largest)"
        ));
    }
    AppError::Organ {
        path: path.to_string(),
        source,
    }
}

/// A pipeline error, attributed to the input it is about: an image's
/// errors to the image (`images[index]`, its path or name), bad settings to
/// the settings, the rest to the mesh `label`. `frame` is the frame the
/// mesh was given in (a mesh mirrored against an image is told which frame
/// to try).
pub fn pipeline_error(label: &str, frame: Frame, images: &[String], e: OrganError) -> AppError {
    let image_path = |index: usize| images.get(index).cloned();
    match e {
        OrganError::Placenta(PlacentaError::MeshFlipped {
            index,
            inside,
            flip,
            flipped_inside,
        }) => {
            let image = image_path(index).unwrap_or_default();
            let fix = if flip.is_lps_ras() {
                let other = match frame {
                    Frame::Ras => "lps",
                    Frame::Lps => "ras",
                };
                format!(
                    "({} -> {}) {:.0}% would: rerun with --mesh-frame {other}",
                    frame.name(),
                    if other == "lps" { "LPS" } else { "RAS" },
                    100.0 * flipped_inside
                )
            } else {
                format!(
                    "{:.0}% would: convert the mesh to the image's frame \
                     (or --no-frame-check)",
                    100.0 * flipped_inside
                )
            };
            AppError::Usage(format!(
                "{label}: only {:.0}% of the mesh lies in the foreground of {image}; mirrored in {} {fix}",
                100.0 * inside,
                flip.describe()
            ))
        }
        OrganError::Placenta(PlacentaError::MeshOutsideForeground { index, .. }) => {
            let path = image_path(index).unwrap_or_else(|| label.to_string());
            AppError::Usage(format!(
                "{label}: {e}; if {path} has no placenta foreground, rerun with --no-frame-check"
            ))
        }
        OrganError::Config(_) => AppError::Usage(e.to_string()),
        OrganError::Placenta(PlacentaError::ImagePullback { index, source }) => {
            let path = image_path(index).unwrap_or_else(|| label.to_string());
            organ(&path, *source)
        }
        OrganError::Placenta(PlacentaError::Pullback(source)) => {
            let index = match *source {
                PullbackError::Disjoint { index, .. } => Some(index),
                _ => None,
            };
            let path = index
                .and_then(image_path)
                .unwrap_or_else(|| label.to_string());
            organ(&path, *source)
        }
        e => organ(label, e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn several_components_say_what_to_do() {
        let e = organ(
            "slab.vtu",
            OrganError::Mesh(MeshError::MultipleComponents { count: 2 }),
        );
        assert!(matches!(e, AppError::Usage(_)));
        assert_eq!(
            e.to_string(),
            "slab.vtu: the mesh has 2 connected components; the placenta pipeline needs one \
             (`unfold repair slab.vtu -o OUT --largest-component` keeps the largest)"
        );
    }

    #[test]
    fn other_mesh_errors_name_the_mesh() {
        let source = OrganError::Mesh(MeshError::MultipleComponents { count: 3 });
        let shown = pipeline_error("m.vtu", Frame::Ras, &[], source);
        assert!(shown.to_string().starts_with("m.vtu: the mesh has 3"));
        let e = pipeline_error(
            "m.vtu",
            Frame::Ras,
            &["a.nii".into()],
            OrganError::Mesh(MeshError::Empty { what: "tets" }),
        );
        assert_eq!(e.to_string(), "m.vtu: the mesh is empty: tets");
        assert!(matches!(e, AppError::Organ { .. }));
    }

    #[test]
    fn an_image_without_foreground_is_named_with_the_way_out() {
        let source = OrganError::Placenta(PlacentaError::MeshOutsideForeground {
            index: 1,
            inside: 0.25,
            threshold: 3.0,
        });
        let text = pipeline_error(
            "m.vtu",
            Frame::Ras,
            &["a.nii".into(), "b.nii".into()],
            source,
        )
        .to_string();
        assert!(text.starts_with("m.vtu: "), "{text}");
        assert!(
            text.ends_with("; if b.nii has no placenta foreground, rerun with --no-frame-check"),
            "{text}"
        );
    }
}

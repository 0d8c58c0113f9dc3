//! The frame of a mesh file's coordinates (RAS or LPS), chosen by a setting
//! or read from the file, and positions turned into RAS.

use crate::app::error::{AppError, at};
use crate::io::Frame;
use crate::mesh::nalgebra::Point3;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The frame of a mesh file's coordinates (`--mesh-frame`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MeshFrame {
    /// 3D Slicer's SPACE= marker in the file, else RAS.
    #[default]
    Auto,
    /// Right, anterior, superior (NIfTI's world frame).
    Ras,
    /// Left, posterior, superior (ITK, DICOM, 3D Slicer).
    Lps,
}

crate::param::named!(MeshFrame { Auto => "auto", Ras => "ras", Lps => "lps" });

/// The frame of a mesh file: `choice`, or for [`MeshFrame::Auto`] the
/// file's Slicer marker (RAS without one).
///
/// # Errors
/// Reading the file (for `auto`).
pub fn mesh_frame(choice: MeshFrame, path: &Path) -> Result<Frame, AppError> {
    Ok(match choice {
        MeshFrame::Ras => Frame::Ras,
        MeshFrame::Lps => Frame::Lps,
        MeshFrame::Auto => {
            let bytes = std::fs::read(path).map_err(|e| at(path, e))?;
            crate::io::mesh_frame_hint(&bytes).unwrap_or(Frame::Ras)
        }
    })
}

/// Positions in `frame` turned into RAS: LPS `(x, y, z)` is RAS
/// `(-x, -y, z)`, a half turn about z (a rotation: orientation and
/// distances are kept).
pub fn to_ras(frame: Frame, positions: &mut [Point3<f64>]) {
    let [sx, sy, sz] = frame.to_ras_signs();
    for p in positions {
        p.x *= sx;
        p.y *= sy;
        p.z *= sz;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_names_round_trip() {
        crate::param::named::check_named::<MeshFrame>();
    }

    #[test]
    fn lps_is_a_half_turn_about_z() {
        let mut p = [Point3::new(1.0, -2.0, 3.0)];
        to_ras(Frame::Lps, &mut p);
        assert_eq!(p[0], Point3::new(-1.0, 2.0, 3.0));
        to_ras(Frame::Ras, &mut p);
        assert_eq!(p[0], Point3::new(-1.0, 2.0, 3.0));
    }
}

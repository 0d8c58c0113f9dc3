//! Transmural layers (`--layers N`): bands of equal depth between S and
//! the hemisphere H, labelled `1` at S to `N` at H.

use crate::app::AppError;
use crate::organs::ventricle::CylinderPoint;

/// Most transmural layers `--layers` takes (the command line's and
/// Python's bound).
pub const MAX_LAYERS: u32 = 100;

/// `--layers n`: the transmural layer of each point, `1` at S to `n` at H:
/// `min(floor(d n) + 1, n)` for the depth `d` in `[0, 1]`.
pub fn transmural_layers(coords: &[CylinderPoint], n: u32) -> Vec<i32> {
    let n = f64::from(n);
    coords
        .iter()
        .map(|c| ((c.depth * n).floor() + 1.0).clamp(1.0, n) as i32)
        .collect()
}

/// A number of layers checked: `1..=`[`MAX_LAYERS`] (none: none).
///
/// # Errors
/// [`AppError::Usage`]: `--layers must be between 1 and 100, got k`.
pub fn check_layers(layers: Option<i64>) -> Result<Option<u32>, AppError> {
    match layers {
        None => Ok(None),
        Some(k) if (1..=i64::from(MAX_LAYERS)).contains(&k) => Ok(Some(k as u32)),
        Some(k) => Err(AppError::Usage(format!(
            "--layers must be between 1 and {MAX_LAYERS}, got {k}"
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layers_run_from_s_to_h() {
        let at = |depth: f64| CylinderPoint {
            xi: 0.0,
            zeta: 0.0,
            depth,
        };
        let coords = [at(0.0), at(0.34), at(0.67), at(1.0)];
        assert_eq!(transmural_layers(&coords, 3), [1, 2, 3, 3]);
        assert_eq!(check_layers(Some(3)).unwrap(), Some(3));
        assert!(check_layers(Some(101)).is_err());
    }
}

//! Soft positional targets (`unfold deform`'s template term).

use super::Template;
use crate::ParamError;
use serde::{Deserialize, Serialize};

/// Soft positional targets: `T = |x_b - t_b|^2` (the first `dim` coordinates)
/// for the vertices `b` that have a target, 0 for the others; labels are
/// ignored and there is no `theta`. Gradient `2 (x_b - t_b)`, Hessian
/// `2 I` (exact, PSD). The objective's vertex weight `w_b` must be non-zero
/// for a target to act.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointTargets {
    /// Target per vertex (`None`: no term); only the first `dim` coordinates
    /// are used.
    pub targets: Vec<Option<[f64; 3]>>,
    /// 2 or 3.
    pub dim: usize,
}

impl PointTargets {
    /// Targets per vertex; `dim` must be 2 or 3 and every target finite.
    pub fn new(targets: Vec<Option<[f64; 3]>>, dim: usize) -> Result<Self, ParamError> {
        if dim != 2 && dim != 3 {
            return Err(ParamError::Dimension {
                what: "point targets",
                dim,
            });
        }
        if let Some(v) = targets
            .iter()
            .position(|t| t.is_some_and(|t| t.iter().any(|c| !c.is_finite())))
        {
            return Err(ParamError::TargetNotFinite { vertex: v });
        }
        Ok(PointTargets { targets, dim })
    }

    /// Targets from `(vertex, target)` pairs for a mesh of `num_vertices`
    /// vertices (for `dim = 2` the third coordinate is ignored). Fails on a
    /// vertex index `>= num_vertices`, a vertex listed twice, a non-finite
    /// target or `dim` not 2 or 3.
    pub fn from_pairs(
        num_vertices: usize,
        dim: usize,
        pairs: &[(usize, [f64; 3])],
    ) -> Result<Self, ParamError> {
        let mut targets = vec![None; num_vertices];
        for &(v, t) in pairs {
            if v >= num_vertices {
                return Err(ParamError::Length {
                    what: "point target vertex index (must be below the vertex count)",
                    expected: num_vertices,
                    found: v,
                });
            }
            if targets[v].is_some() {
                return Err(ParamError::TargetRepeated { vertex: v });
            }
            targets[v] = Some(t);
        }
        Self::new(targets, dim)
    }

    /// The target of `vertex`, if any.
    #[inline]
    pub fn target(&self, vertex: usize) -> Option<&[f64; 3]> {
        self.targets.get(vertex).and_then(|t| t.as_ref())
    }

    /// Number of vertices with a target.
    pub fn count(&self) -> usize {
        self.targets.iter().filter(|t| t.is_some()).count()
    }
}

impl Template for PointTargets {
    fn name(&self) -> &'static str {
        "point-targets"
    }

    fn parameter_names(&self) -> Vec<&'static str> {
        Vec::new()
    }

    fn value(&self, vertex: usize, _label: u8, x: &[f64], _theta: &[f64]) -> f64 {
        match self.target(vertex) {
            Some(t) => (0..self.dim.min(x.len()))
                .map(|c| (x[c] - t[c]) * (x[c] - t[c]))
                .sum(),
            None => 0.0,
        }
    }

    fn gradient(&self, vertex: usize, _label: u8, x: &[f64], _theta: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        if let Some(t) = self.target(vertex) {
            for c in 0..self.dim.min(x.len()) {
                out[c] = 2.0 * (x[c] - t[c]);
            }
        }
    }

    fn hessian(&self, vertex: usize, _label: u8, x: &[f64], _theta: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        if self.target(vertex).is_some() {
            let d = x.len();
            for c in 0..self.dim.min(d) {
                out[c * d + c] = 2.0;
            }
        }
    }

    fn theta_gradient(
        &self,
        _vertex: usize,
        _label: u8,
        _x: &[f64],
        _theta: &[f64],
        _out: &mut [f64],
    ) {
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::template::check::template_derivatives;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        #[test]
        fn point_targets_derivatives_match_fd(
            x in [-20.0..20.0f64, -20.0..20.0, -20.0..20.0],
            target in [-20.0..20.0f64, -20.0..20.0, -20.0..20.0],
            dim in 2usize..4,
        ) {
            let t = PointTargets::from_pairs(3, dim, &[(1, target)]).unwrap();
            let x = &x[..dim];
            prop_assert!(template_derivatives(&t, 1, 0, x, &[], 1e-6).is_ok());
            prop_assert!(template_derivatives(&t, 0, 1, x, &[], 1e-6).is_ok());
            prop_assert_eq!(t.value(0, 1, x, &[]), 0.0);
            prop_assert_eq!(t.value(1, 1, &target[..dim], &[]), 0.0);
            let expected: f64 = (0..dim).map(|c| (x[c] - target[c]).powi(2)).sum();
            prop_assert!((t.value(1, 0, x, &[]) - expected).abs() <= 1e-12 * (1.0 + expected));
        }
    }

    #[test]
    fn point_targets_describe_themselves() {
        let t = PointTargets::from_pairs(3, 3, &[(1, [0.0; 3])]).unwrap();
        assert_eq!(t.name(), "point-targets");
        assert!(t.parameter_names().is_empty());
    }

    #[test]
    fn point_targets_reject_bad_input() {
        assert!(matches!(
            PointTargets::from_pairs(3, 3, &[(3, [0.0; 3])]),
            Err(ParamError::Length { .. })
        ));
        assert!(matches!(
            PointTargets::from_pairs(3, 3, &[(1, [0.0; 3]), (1, [1.0; 3])]),
            Err(ParamError::TargetRepeated { vertex: 1 })
        ));
        assert!(matches!(
            PointTargets::from_pairs(3, 3, &[(1, [f64::NAN, 0.0, 0.0])]),
            Err(ParamError::TargetNotFinite { vertex: 1 })
        ));
        assert!(matches!(
            PointTargets::from_pairs(3, 4, &[]),
            Err(ParamError::Dimension { dim: 4, .. })
        ));
        assert!(PointTargets::from_pairs(3, 1, &[]).is_err());
        let t = PointTargets::from_pairs(4, 2, &[(0, [1.0, 2.0, 99.0]), (3, [0.0; 3])]).unwrap();
        assert_eq!(t.count(), 2);
        assert_eq!(t.value(0, 0, &[1.0, 2.0], &[]), 0.0);
        assert_eq!(t.value(0, 0, &[2.0, 2.0], &[]), 1.0);
        // A vertex beyond the table has no target.
        assert_eq!(t.value(10, 0, &[2.0, 2.0], &[]), 0.0);
    }
}

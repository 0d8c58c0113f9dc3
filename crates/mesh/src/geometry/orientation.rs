//! Orientation of a planar triangle map: signed areas, the majority
//! orientation and the flipped triangles.
//!
//! A triangle `(q0, q1, q2)` of a map to the plane has the doubled signed
//! area
//!
//! ```text
//! s = (q1 - q0) x (q2 - q0) = (q1x - q0x)(q2y - q0y) - (q1y - q0y)(q2x - q0x)
//! ```
//!
//! (positive counter-clockwise). A map may be wound either way (a mirror
//! is as good a flattening), so orientation is judged against the
//! **majority**: with `P` the triangles with `s > 0` and `N` those with
//! `s < 0`,
//!
//! - the majority sign is `+1` when `P > N`, `-1` when `P < N`, and on a
//!   tie the sign of `sum s` (`+1` when the sum is `>= 0`, `-1` when it is
//!   negative or NaN);
//! - a triangle is **flipped** when `sign * s <= 0` or `s` is NaN: a
//!   triangle of the minority orientation, and every **degenerate** one
//!   (`s == 0` or NaN), whatever the majority. Degenerate triangles never
//!   vote for the majority.
//!
//! So the number of flipped triangles is `min(P, N) + D` (`D` degenerate):
//! the tie rule of the sign does not change the count, only which way a
//! caller that mirrors the map turns it.

/// Twice the signed area `(q1 - q0) x (q2 - q0)` of every triangle of the
/// map `uv`, in triangle order (positive counter-clockwise; see the module
/// doc). Half of it is [`super::triangle_signed_area_2d`].
///
/// # Panics
/// When a triangle refers to a vertex out of range of `uv`.
pub fn twice_signed_areas_2d(uv: &[[f64; 2]], triangles: &[[u32; 3]]) -> Vec<f64> {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| uv[v as usize]);
            (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        })
        .collect()
}

/// How many signed areas are positive, negative and degenerate (zero or
/// NaN): `positive + negative + degenerate` is the number of areas.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Orientations {
    /// Areas `s > 0` (counter-clockwise triangles).
    pub positive: usize,
    /// Areas `s < 0` (clockwise triangles).
    pub negative: usize,
    /// Areas `s == 0` or NaN: flipped whatever the majority.
    pub degenerate: usize,
}

impl Orientations {
    /// Counts the signs of `areas` (e.g. [`twice_signed_areas_2d`]).
    pub fn count(areas: &[f64]) -> Orientations {
        let mut c = Orientations::default();
        for &s in areas {
            if s > 0.0 {
                c.positive += 1;
            } else if s < 0.0 {
                c.negative += 1;
            } else {
                c.degenerate += 1;
            }
        }
        c
    }

    /// The flipped triangles against the majority (module doc):
    /// `min(positive, negative) + degenerate`.
    pub fn flipped(&self) -> usize {
        self.positive.min(self.negative) + self.degenerate
    }
}

/// The majority orientation of `areas` (module doc): `+1.0` when more areas
/// are positive than negative, `-1.0` when fewer; on a tie `+1.0` when
/// `sum areas >= 0` and `-1.0` otherwise (also for a NaN sum). Degenerate
/// areas (zero, NaN) do not vote.
pub fn majority_sign(areas: &[f64]) -> f64 {
    let c = Orientations::count(areas);
    if c.positive > c.negative || (c.positive == c.negative && areas.iter().sum::<f64>() >= 0.0) {
        1.0
    } else {
        -1.0
    }
}

/// Indices, ascending, of the areas that are not strictly of orientation
/// `sign` (`sign * s <= 0` or NaN): the flipped triangles when `sign` is
/// [`majority_sign`].
pub fn flipped_indices(areas: &[f64], sign: f64) -> Vec<usize> {
    areas
        .iter()
        .enumerate()
        .filter(|&(_, &a)| (sign * a).is_nan() || sign * a <= 0.0)
        .map(|(t, _)| t)
        .collect()
}

/// The number of flipped triangles of the planar map `uv` (module doc):
/// those of the minority orientation plus the degenerate ones (zero or NaN
/// area), `min(P, N) + D`; 0 for an injective map either way round.
///
/// Orientation is judged against the majority; the local overlap test that
/// does not trust orientation at all is [`super::folded_edges`].
///
/// # Panics
/// When a triangle refers to a vertex out of range of `uv`.
pub fn flipped_triangles(uv: &[[f64; 2]], triangles: &[[u32; 3]]) -> usize {
    Orientations::count(&twice_signed_areas_2d(uv, triangles)).flipped()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A `w x h` grid of unit squares, two counter-clockwise triangles each.
    fn grid(w: u32, h: u32) -> (Vec<[f64; 2]>, Vec<[u32; 3]>) {
        let mut uv = Vec::new();
        for j in 0..=h {
            for i in 0..=w {
                uv.push([i as f64, j as f64]);
            }
        }
        let mut tris = Vec::new();
        for j in 0..h {
            for i in 0..w {
                let a = i + (w + 1) * j;
                tris.push([a, a + 1, a + w + 2]);
                tris.push([a, a + w + 2, a + w + 1]);
            }
        }
        (uv, tris)
    }

    #[test]
    fn areas_and_the_tie_rule() {
        let uv = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [2.0, 0.0]];
        // ccw, cw, degenerate (collinear)
        let tris = [[0, 1, 2], [0, 2, 1], [0, 1, 3]];
        let s = twice_signed_areas_2d(&uv, &tris);
        assert_eq!(s, vec![1.0, -1.0, 0.0]);
        let c = Orientations::count(&s);
        assert_eq!(
            c,
            Orientations {
                positive: 1,
                negative: 1,
                degenerate: 1
            }
        );
        // Tie: the sum (0) decides for +1; either way 2 are flipped.
        assert_eq!(majority_sign(&s), 1.0);
        assert_eq!(flipped_indices(&s, 1.0), vec![1, 2]);
        assert_eq!(flipped_indices(&s, -1.0), vec![0, 2]);
        assert_eq!(flipped_triangles(&uv, &tris), 2);
        // A tie with a negative or NaN sum goes to -1.
        assert_eq!(majority_sign(&[1.0, -2.0]), -1.0);
        assert_eq!(majority_sign(&[f64::NAN]), -1.0);
        assert_eq!(majority_sign(&[]), 1.0);
        // Degenerate triangles never vote: 3 positive against 4 zero areas
        // leave +1 the majority and 4 flipped.
        let s = [1.0, 1.0, 1.0, 0.0, 0.0, f64::NAN, -0.0];
        assert_eq!(majority_sign(&s), 1.0);
        assert_eq!(flipped_indices(&s, 1.0), vec![3, 4, 5, 6]);
        assert_eq!(Orientations::count(&s).flipped(), 4);
        assert_eq!(flipped_triangles(&[], &[]), 0);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// The count is `flipped_indices` against `majority_sign`, for any
        /// map; a grid rotated or mirrored has none, and pulling a vertex
        /// across its neighbours flips the same triangles either way round.
        #[test]
        fn flipped_count_is_the_minority_plus_degenerate(
            uv in prop::collection::vec(prop::array::uniform2(-3i32..3), 16),
            angle in 0.0f64..6.3,
            mirror in any::<bool>(),
        ) {
            let (_, tris) = grid(3, 3);
            let uv: Vec<[f64; 2]> = uv.iter().map(|q| [q[0] as f64, q[1] as f64]).collect();
            let s = twice_signed_areas_2d(&uv, &tris);
            let by_indices = flipped_indices(&s, majority_sign(&s)).len();
            prop_assert_eq!(flipped_triangles(&uv, &tris), by_indices);
            let c = Orientations::count(&s);
            prop_assert_eq!(c.positive + c.negative + c.degenerate, tris.len());
            let brute = s.iter().filter(|&&a| a > 0.0).count()
                .min(s.iter().filter(|&&a| a < 0.0).count())
                + s.iter().filter(|&&a| a == 0.0).count();
            prop_assert_eq!(by_indices, brute);

            let (grid_uv, _) = grid(3, 3);
            let (co, si) = (angle.cos(), angle.sin());
            let mut moved: Vec<[f64; 2]> = grid_uv
                .iter()
                .map(|q| {
                    let x = if mirror { -q[0] } else { q[0] };
                    [co * x - si * q[1], si * x + co * q[1]]
                })
                .collect();
            prop_assert_eq!(flipped_triangles(&moved, &tris), 0);
            // vertex (1, 1) pulled past (2, 2)
            let (a, b) = (moved[5], moved[10]);
            moved[5] = [a[0] + 1.5 * (b[0] - a[0]), a[1] + 1.5 * (b[1] - a[1])];
            prop_assert!(flipped_triangles(&moved, &tris) > 0);
            let mirrored: Vec<[f64; 2]> = moved.iter().map(|q| [-q[0], q[1]]).collect();
            prop_assert_eq!(
                flipped_triangles(&mirrored, &tris),
                flipped_triangles(&moved, &tris)
            );
        }
    }
}

//! Line segments chained into one polyline (an annulus ring, a curve that
//! another tool exported as separate 2-point lines).
//!
//! The segments must form one simple path or one simple loop: every vertex
//! is used by at most two segments. The chain starts at an end of the path
//! (the one its segment leaves, else the smaller-numbered one) or, for a
//! loop, at its smallest vertex,
//! continuing through the segment that starts there (so consistently
//! directed segments keep their direction), else its first in file order;
//! a loop ends by repeating its first vertex.

use thiserror::Error;

/// Why segments do not chain into one polyline.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ChainError {
    /// No segment.
    #[error("there are no line segments to chain")]
    Empty,
    /// A segment joins a vertex to itself.
    #[error("segment {segment} joins vertex {vertex} to itself")]
    Loop {
        /// The segment.
        segment: usize,
        /// Its vertex.
        vertex: u32,
    },
    /// A vertex is used by more than two segments (a branch).
    #[error("vertex {vertex} is used by {degree} segments (the curve branches there)")]
    Branch {
        /// The vertex.
        vertex: u32,
        /// Segments using it.
        degree: usize,
    },
    /// The segments form several separate pieces.
    #[error("the segments form {pieces} separate pieces, expected one curve")]
    Pieces {
        /// Number of pieces.
        pieces: usize,
    },
}

/// The vertices of `segments` in curve order (see the module doc); a loop
/// repeats its first vertex at the end.
///
/// # Errors
/// [`ChainError`] for no segment, a degenerate segment, a branch or several
/// pieces.
pub fn chain_segments(segments: &[[u32; 2]]) -> Result<Vec<u32>, ChainError> {
    if segments.is_empty() {
        return Err(ChainError::Empty);
    }
    // vertex -> the (at most two) segments using it
    let mut uses: std::collections::BTreeMap<u32, Vec<usize>> = std::collections::BTreeMap::new();
    for (s, &[a, b]) in segments.iter().enumerate() {
        if a == b {
            return Err(ChainError::Loop {
                segment: s,
                vertex: a,
            });
        }
        for v in [a, b] {
            let u = uses.entry(v).or_default();
            u.push(s);
            if u.len() > 2 {
                return Err(ChainError::Branch {
                    vertex: v,
                    degree: u.len(),
                });
            }
        }
    }
    // A path starts at an end, the one its segment leaves where there is
    // one; a loop at its smallest vertex.
    let ends: Vec<u32> = uses
        .iter()
        .filter(|(_, u)| u.len() == 1)
        .map(|(&v, _)| v)
        .collect();
    let start = ends
        .iter()
        .copied()
        .find(|&v| segments[uses[&v][0]][0] == v)
        .or_else(|| ends.first().copied())
        .or_else(|| uses.keys().next().copied())
        .ok_or(ChainError::Empty)?;
    let mut used = vec![false; segments.len()];
    let mut out = vec![start];
    let mut at = start;
    // Along the segments' own direction where they give one: first through
    // a segment that starts at the start vertex.
    let first = uses[&start]
        .iter()
        .copied()
        .find(|&s| segments[s][0] == start)
        .unwrap_or(uses[&start][0]);
    let mut next = Some(first);
    while let Some(s) = next {
        used[s] = true;
        let [a, b] = segments[s];
        at = if a == at { b } else { a };
        out.push(at);
        next = uses[&at].iter().copied().find(|&t| !used[t]);
    }
    let left = used.iter().filter(|u| !**u).count();
    if left > 0 {
        // count the pieces: each further chain from an unused segment
        let mut pieces = 1;
        let mut used2 = used;
        for s0 in 0..segments.len() {
            if used2[s0] {
                continue;
            }
            pieces += 1;
            let mut stack = vec![s0];
            used2[s0] = true;
            while let Some(s) = stack.pop() {
                for v in segments[s] {
                    for &t in &uses[&v] {
                        if !used2[t] {
                            used2[t] = true;
                            stack.push(t);
                        }
                    }
                }
            }
        }
        return Err(ChainError::Pieces { pieces });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// A loop or path cut into segments, shuffled and with some
        /// segments reversed, chains back into the same cyclic sequence (a
        /// loop, either direction) or the same path (either direction).
        #[test]
        fn shuffled_segments_chain_back(
            n in 3usize..40,
            closed in any::<bool>(),
            seed in any::<u64>(),
        ) {
            let order: Vec<u32> = {
                // a permutation of vertex ids, so order is not numbering
                let mut v: Vec<u32> = (0..n as u32).collect();
                let mut s = seed;
                for i in (1..n).rev() {
                    s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    v.swap(i, (s >> 33) as usize % (i + 1));
                }
                v
            };
            let m = if closed { n } else { n - 1 };
            let mut segs: Vec<[u32; 2]> =
                (0..m).map(|i| [order[i], order[(i + 1) % n]]).collect();
            let mut s = seed ^ 0x9e37;
            for i in (1..segs.len()).rev() {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                segs.swap(i, (s >> 33) as usize % (i + 1));
                if (s >> 20) & 1 == 1 {
                    segs[i].reverse();
                }
            }
            let chain = chain_segments(&segs).unwrap();
            // Directed segments (none reversed) keep their direction.
            let directed: Vec<[u32; 2]> =
                (0..m).map(|i| [order[i], order[(i + 1) % n]]).rev().collect();
            let forward = chain_segments(&directed).unwrap();
            for w in forward.windows(2) {
                prop_assert!(directed.contains(&[w[0], w[1]]), "{w:?} against the segments");
            }
            prop_assert_eq!(chain.len(), if closed { n + 1 } else { n });
            if closed {
                prop_assert_eq!(chain[0], chain[n]);
            }
            // consecutive chain vertices are consecutive on the curve
            for w in chain.windows(2) {
                let i = order.iter().position(|&v| v == w[0]).unwrap();
                let j = order.iter().position(|&v| v == w[1]).unwrap();
                let d = (i as i64 - j as i64).rem_euclid(n as i64);
                prop_assert!(d == 1 || d == n as i64 - 1, "{w:?}");
            }
        }
    }

    #[test]
    fn branches_pieces_and_degenerate_segments_are_refused() {
        assert_eq!(chain_segments(&[]), Err(ChainError::Empty));
        assert_eq!(
            chain_segments(&[[0, 1], [1, 1]]),
            Err(ChainError::Loop {
                segment: 1,
                vertex: 1
            })
        );
        assert_eq!(
            chain_segments(&[[0, 1], [1, 2], [1, 3]]),
            Err(ChainError::Branch {
                vertex: 1,
                degree: 3
            })
        );
        assert_eq!(
            chain_segments(&[[0, 1], [1, 2], [2, 0], [5, 6]]),
            Err(ChainError::Pieces { pieces: 2 })
        );
    }
}

//! The relabelings a permutation test runs: the identity first, then
//! either every distinct relabeling (exhaustive) or a seeded random stream.
//!
//! A relabeling is an index array `src` of length `n`: subject `j` takes
//! the design row of subject `src[j]`. Permuting design rows by `src` is
//! the same as permuting the data by its inverse, so a uniform random
//! `src` is a uniform random permutation of the data.
//!
//! The random stream is deterministic for a seed whatever the thread
//! count: relabeling `k` is drawn by Fisher-Yates from its own SplitMix64
//! generator (Steele, Lea & Flood, "Fast splittable pseudorandom number
//! generators", OOPSLA 2014) whose state is derived from `(seed, k)`, with
//! bounded integers by Lemire's multiply-shift rejection ("Fast random
//! integer generation in an interval", ACM TOMACS 2019).

/// The relabelings of one test.
#[derive(Debug, Clone)]
pub(crate) enum Shuffles {
    /// Every distinct relabeling, the identity first.
    Listed(Vec<Vec<u32>>),
    /// The identity, then `count - 1` seeded random permutations.
    Random { count: usize, seed: u64 },
}

impl Shuffles {
    /// Plans the relabelings of `n` subjects for at most `permutations`
    /// runs: exhaustive when the number of distinct relabelings is at most
    /// `permutations` (with `labels` given, the multinomial count
    /// `n! / prod(n_i!)` of distinct group assignments; otherwise `n!`),
    /// random otherwise.
    pub(crate) fn plan(
        n: usize,
        labels: Option<(&[usize], usize)>,
        permutations: usize,
        seed: u64,
    ) -> Shuffles {
        let limit = permutations as u128;
        match labels {
            Some((labels, levels)) => {
                let mut counts = vec![0usize; levels];
                for &l in labels {
                    counts[l] += 1;
                }
                if multinomial_at_most(&counts, limit).is_some() {
                    return Shuffles::Listed(relabelings(labels));
                }
            }
            None => {
                if factorial_at_most(n, limit).is_some() {
                    let identity: Vec<usize> = (0..n).collect();
                    return Shuffles::Listed(relabelings(&identity));
                }
            }
        }
        Shuffles::Random {
            count: permutations,
            seed,
        }
    }

    /// How many relabelings (identity included).
    pub(crate) fn len(&self) -> usize {
        match self {
            Shuffles::Listed(list) => list.len(),
            Shuffles::Random { count, .. } => *count,
        }
    }

    /// Whether every distinct relabeling is enumerated.
    pub(crate) fn exhaustive(&self) -> bool {
        matches!(self, Shuffles::Listed(_))
    }

    /// Writes relabeling `k` into `src` (length `n`).
    pub(crate) fn fill(&self, k: usize, src: &mut [u32]) {
        match self {
            Shuffles::Listed(list) => src.copy_from_slice(&list[k]),
            Shuffles::Random { seed, .. } => {
                for (i, s) in src.iter_mut().enumerate() {
                    *s = i as u32;
                }
                if k == 0 {
                    return;
                }
                let mut rng = SplitMix64::new(*seed, k as u64);
                for i in (1..src.len()).rev() {
                    let j = rng.below(i as u64 + 1) as usize;
                    src.swap(i, j);
                }
            }
        }
    }
}

/// `n!` when it is at most `limit`.
fn factorial_at_most(n: usize, limit: u128) -> Option<u128> {
    let mut f: u128 = 1;
    for i in 2..=n as u128 {
        f = f.checked_mul(i)?;
        if f > limit {
            return None;
        }
    }
    (f <= limit).then_some(f)
}

/// `(sum n_i)! / prod(n_i!)` when it is at most `limit`, built as a product
/// of binomials `C(m + c, c)`, each grown one factor at a time (exact
/// integer steps, monotone, so the first excess stops it).
fn multinomial_at_most(counts: &[usize], limit: u128) -> Option<u128> {
    let mut total: u128 = 1;
    let mut m: u128 = 0;
    for &c in counts {
        let mut binom: u128 = 1;
        for i in 1..=c as u128 {
            binom = binom.checked_mul(m + i)? / i;
            if binom.checked_mul(total)? > limit {
                return None;
            }
        }
        total = total.checked_mul(binom)?;
        m += c as u128;
    }
    (total <= limit).then_some(total)
}

/// Every distinct rearrangement of the multiset `labels`, as relabelings
/// (`src[j]` a subject whose label is the rearrangement's `j`-th), the
/// identity first. Rearrangements come in lexicographic order (the
/// classical next-permutation step, which skips repeats); the identity's
/// rearrangement is then swapped to the front.
fn relabelings(labels: &[usize]) -> Vec<Vec<u32>> {
    let n = labels.len();
    let levels = labels.iter().max().map_or(0, |m| m + 1);
    let mut of_level: Vec<Vec<u32>> = vec![Vec::new(); levels];
    for (i, &l) in labels.iter().enumerate() {
        of_level[l].push(i as u32);
    }
    let mut arrangement = labels.to_vec();
    arrangement.sort_unstable();
    let mut out = Vec::new();
    let mut identity_at = 0;
    loop {
        let mut next = vec![0usize; levels];
        let src: Vec<u32> = arrangement
            .iter()
            .map(|&l| {
                let s = of_level[l][next[l]];
                next[l] += 1;
                s
            })
            .collect();
        if arrangement == labels {
            identity_at = out.len();
        }
        out.push(src);
        if !next_permutation(&mut arrangement) {
            break;
        }
    }
    out.swap(0, identity_at);
    debug_assert!(out[0].iter().enumerate().all(|(i, &s)| s as usize == i) || n == 0);
    out
}

/// Steps `a` to the next lexicographic arrangement; false after the last.
fn next_permutation(a: &mut [usize]) -> bool {
    if a.len() < 2 {
        return false;
    }
    let mut i = a.len() - 1;
    while i > 0 && a[i - 1] >= a[i] {
        i -= 1;
    }
    if i == 0 {
        return false;
    }
    let mut j = a.len() - 1;
    while a[j] <= a[i - 1] {
        j -= 1;
    }
    a.swap(i - 1, j);
    a[i..].reverse();
    true
}

/// SplitMix64: a 64-bit state advanced by the golden-ratio increment and
/// finalized by two xor-shift-multiply rounds.
struct SplitMix64(u64);

const GOLDEN: u64 = 0x9e37_79b9_7f4a_7c15;

fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl SplitMix64 {
    /// The generator of stream `k` under `seed`.
    fn new(seed: u64, k: u64) -> SplitMix64 {
        SplitMix64(mix(seed ^ mix(k.wrapping_mul(GOLDEN))))
    }

    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(GOLDEN);
        mix(self.0)
    }

    /// Uniform in `0..bound` (`bound >= 1`).
    fn below(&mut self, bound: u64) -> u64 {
        let threshold = bound.wrapping_neg() % bound;
        loop {
            let m = u128::from(self.next()) * u128::from(bound);
            if (m as u64) >= threshold {
                return (m >> 64) as u64;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_enumerations_agree() {
        assert_eq!(factorial_at_most(6, 1000), Some(720));
        assert_eq!(factorial_at_most(7, 1000), None);
        assert_eq!(multinomial_at_most(&[3, 4], 1000), Some(35));
        assert_eq!(multinomial_at_most(&[2, 2, 3], 1000), Some(210));
        assert_eq!(multinomial_at_most(&[10, 10], 1000), None);
        let labels = [1, 0, 2, 1, 0, 2, 2];
        let list = relabelings(&labels);
        assert_eq!(list.len(), 210);
        assert_eq!(list[0], (0..7).collect::<Vec<u32>>());
        let mut seen: Vec<Vec<usize>> = list
            .iter()
            .map(|s| s.iter().map(|&i| labels[i as usize]).collect())
            .collect();
        seen.sort();
        seen.dedup();
        assert_eq!(seen.len(), 210);
    }

    #[test]
    fn random_stream_is_a_seeded_permutation() {
        let shuffles = Shuffles::Random { count: 50, seed: 7 };
        let mut a = vec![0u32; 30];
        let mut b = vec![0u32; 30];
        shuffles.fill(0, &mut a);
        assert_eq!(a, (0..30).collect::<Vec<u32>>());
        shuffles.fill(17, &mut a);
        shuffles.fill(17, &mut b);
        assert_eq!(a, b);
        let mut sorted = a.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..30).collect::<Vec<u32>>());
        Shuffles::Random { count: 50, seed: 8 }.fill(17, &mut b);
        assert_ne!(a, b);
    }
}

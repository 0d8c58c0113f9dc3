//! Memory estimates: what a stage will allocate, predicted from the sizes
//! of its inputs and options before it allocates anything (issue 18).
//!
//! A stage's estimate is a sum of named parts, each a count times the
//! bytes one item holds at the stage's peak (the buffers alive together),
//! e.g. the mesher's lattice, `vertices x bytes per lattice vertex`. The
//! per-item constants are the sizes of the data structures, with the
//! allocator's slack and the copies a stage makes measured on real runs
//! (the tests compare the estimate with the measured peak resident size of
//! the process). A caller compares `resident now + estimate` with the
//! memory it may use and refuses before the work starts.

use serde::Serialize;
use std::fmt;

/// One part of an estimate: what it is and its bytes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MemoryPart {
    /// What is allocated (e.g. "lattice").
    pub what: &'static str,
    /// Bytes (a real: a runaway option may not fit an integer).
    pub bytes: f64,
}

/// The memory a stage will allocate: a sum of named parts.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct MemoryEstimate {
    /// The parts, in the order they were added.
    pub parts: Vec<MemoryPart>,
}

impl MemoryEstimate {
    /// An empty estimate.
    pub fn new() -> Self {
        Self::default()
    }

    /// This estimate with a part `what` of `count x bytes_each` bytes.
    pub fn with(mut self, what: &'static str, count: f64, bytes_each: f64) -> Self {
        self.add(what, count * bytes_each);
        self
    }

    /// Adds a part of `bytes` bytes.
    pub fn add(&mut self, what: &'static str, bytes: f64) {
        self.parts.push(MemoryPart {
            what,
            bytes: bytes.max(0.0),
        });
    }

    /// Adds every part of `other`.
    pub fn extend(&mut self, other: &MemoryEstimate) {
        self.parts.extend_from_slice(&other.parts);
    }

    /// The sum of the parts, bytes.
    pub fn total(&self) -> f64 {
        self.parts.iter().map(|p| p.bytes).sum()
    }

    /// The largest part, if any.
    pub fn largest(&self) -> Option<MemoryPart> {
        self.parts
            .iter()
            .copied()
            .max_by(|a, b| a.bytes.total_cmp(&b.bytes))
    }
}

/// `bytes` for people: `"512 B"`, `"3.2 MiB"`, `"1.5 GiB"`, `"2.0e6 TiB"`;
/// infinite: `"an unbounded amount"`.
pub fn format_bytes(bytes: f64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    if !bytes.is_finite() {
        return "an unbounded amount".to_string();
    }
    let mut v = bytes.max(0.0);
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    match u {
        0 => format!("{v:.0} B"),
        _ if v >= 1e5 => format!("{v:.1e} {}", UNITS[u]),
        _ => format!("{v:.1} {}", UNITS[u]),
    }
}

impl fmt::Display for MemoryEstimate {
    /// `"1.2 GiB (lattice 1.0 GiB, tets 200.0 MiB)"`, the parts largest
    /// first.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = self.parts.clone();
        parts.sort_by(|a, b| b.bytes.total_cmp(&a.bytes));
        write!(f, "{}", format_bytes(self.total()))?;
        if !parts.is_empty() {
            let list: Vec<String> = parts
                .iter()
                .filter(|p| p.bytes > 0.0)
                .map(|p| format!("{} {}", p.what, format_bytes(p.bytes)))
                .collect();
            write!(f, " ({})", list.join(", "))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn parts_add_up_and_print_largest_first() {
        let e = MemoryEstimate::new()
            .with("tets", 1000.0, 16.0)
            .with("lattice", 1e6, 72.0);
        assert_eq!(e.total(), 16_000.0 + 72e6);
        assert_eq!(e.largest().map(|p| p.what), Some("lattice"));
        let s = e.to_string();
        assert!(
            s.starts_with("68.7 MiB (lattice 68.7 MiB, tets 15.6 KiB)"),
            "{s}"
        );
    }

    #[test]
    fn huge_and_odd_sizes_print() {
        assert_eq!(format_bytes(0.0), "0 B");
        assert_eq!(format_bytes(1023.0), "1023 B");
        assert_eq!(format_bytes(1536.0), "1.5 KiB");
        assert!(
            format_bytes(1e30).ends_with("TiB"),
            "{}",
            format_bytes(1e30)
        );
        assert_eq!(format_bytes(f64::INFINITY), "an unbounded amount");
    }

    proptest! {
        #[test]
        fn total_is_the_sum_and_never_negative(parts in proptest::collection::vec(-1e9f64..1e12, 0..8)) {
            let mut e = MemoryEstimate::new();
            for p in &parts {
                e.add("x", *p);
            }
            let sum: f64 = parts.iter().map(|p| p.max(0.0)).sum();
            prop_assert!((e.total() - sum).abs() <= 1e-9 * sum.max(1.0));
            prop_assert!(e.total() >= 0.0);
        }
    }
}

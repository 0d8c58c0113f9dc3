//! A process-wide cap on the bytes the readers inflate (issue 18).
//!
//! A compressed array may announce what it can hold (tuples x components x
//! type size, at most about 1032 times its compressed size), so a small
//! file can still hold gigabytes legitimately. The command-line tool sets
//! this cap to the memory the run may use; every inflation claims its
//! announced size first and is refused, before anything is inflated, when
//! the claims of the process pass the cap. Unset (the default for a
//! library user), nothing is capped.

use std::sync::atomic::{AtomicU64, Ordering};

static LIMIT: AtomicU64 = AtomicU64::new(u64::MAX);
static CLAIMED: AtomicU64 = AtomicU64::new(0);

/// Caps the bytes all readers of this process may inflate (`None`: no
/// cap).
pub fn set_decode_limit(bytes: Option<u64>) {
    LIMIT.store(bytes.unwrap_or(u64::MAX), Ordering::Relaxed);
}

/// Claims `bytes` of inflated data; the message when the claims of the
/// process would pass the cap.
pub(crate) fn claim(bytes: u64) -> Result<(), String> {
    claim_in(&LIMIT, &CLAIMED, bytes)
}

/// [`claim`] against the given cap and running total.
fn claim_in(limit: &AtomicU64, claimed: &AtomicU64, bytes: u64) -> Result<(), String> {
    let limit = limit.load(Ordering::Relaxed);
    let before = claimed.fetch_add(bytes, Ordering::Relaxed);
    let after = before.saturating_add(bytes);
    if after > limit {
        claimed.fetch_sub(bytes, Ordering::Relaxed);
        return Err(format!(
            "inflating {bytes} more bytes ({after} in all) would pass the {limit} bytes this run \
             may use (--max-memory, else what is available)"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn claims_beyond_the_cap_are_refused_and_not_counted() {
        // local counters: the globals are shared with the readers' tests
        let (limit, claimed) = (AtomicU64::new(1000), AtomicU64::new(0));
        assert!(claim_in(&limit, &claimed, 400).is_ok());
        let e = claim_in(&limit, &claimed, 700).unwrap_err();
        assert!(e.contains("700 more bytes (1100 in all)"), "{e}");
        assert_eq!(claimed.load(Ordering::Relaxed), 400);
        assert!(claim_in(&limit, &claimed, 600).is_ok());
        let unlimited = AtomicU64::new(u64::MAX);
        assert!(claim_in(&unlimited, &claimed, u64::MAX / 2).is_ok());
    }
}

//! The memory a run may use, and the check before each big allocation.
//!
//! The limit is `--max-memory` when given, else the memory available to
//! the process: the least of the system's `MemAvailable` (`/proc/meminfo`)
//! and the room left under a cgroup limit (`memory.max - memory.current`,
//! cgroup v2; `memory.limit_in_bytes - memory.usage_in_bytes`, v1). Where
//! none of these can be read there is no limit.
//!
//! Before a stage allocates, its estimate ([`MemoryEstimate`], from the
//! sizes of its inputs and options) is added to the process's resident size
//! now (`VmRSS`); a predicted peak above the limit is refused with the
//! estimate's parts and what to change, before anything is allocated. The
//! highest prediction and the measured peak (`VmHWM`) go into the reports.

use crate::app::AppError;
use crate::mesh::memory::{MemoryEstimate, format_bytes};
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};

/// Where the limit comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LimitSource {
    /// `--max-memory`.
    Flag,
    /// The system's available memory or the cgroup's room.
    Available,
    /// Nothing known: no limit.
    Unknown,
}

/// The memory a run may use.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Budget {
    /// Bytes, `None` for no limit.
    pub limit_bytes: Option<f64>,
    /// Where it comes from.
    pub source: LimitSource,
}

static BUDGET: OnceLock<Budget> = OnceLock::new();
/// The highest predicted peak of the run so far, bytes.
static PREDICTED: AtomicU64 = AtomicU64::new(0);
/// The parts of the check that made [`PREDICTED`]: the resident size and
/// the stage's estimate.
static PREDICTED_PARTS: Mutex<Vec<PredictedPart>> = Mutex::new(Vec::new());

/// Sets the run's budget from `--max-memory` (or what is available); the
/// first call wins.
pub fn init(max_memory: Option<u64>) {
    let budget = match max_memory {
        Some(b) => Budget {
            limit_bytes: Some(b as f64),
            source: LimitSource::Flag,
        },
        None => match available_bytes() {
            Some(b) => Budget {
                limit_bytes: Some(b),
                source: LimitSource::Available,
            },
            None => Budget {
                limit_bytes: None,
                source: LimitSource::Unknown,
            },
        },
    };
    let _ = BUDGET.set(budget);
    crate::io::set_decode_limit(room().map(|r| r as u64));
}

/// The run's budget (no limit before [`init`]).
pub fn budget() -> Budget {
    BUDGET.get().copied().unwrap_or(Budget {
        limit_bytes: None,
        source: LimitSource::Unknown,
    })
}

/// Refuses `stage` when the resident size now plus `estimate` exceeds the
/// budget; `hint` says what to change. Records the prediction.
///
/// # Errors
/// [`AppError::Memory`] with the prediction, its parts and the limit.
pub fn check(
    stage: &'static str,
    estimate: &MemoryEstimate,
    hint: &'static str,
) -> Result<(), AppError> {
    let resident = resident_bytes().unwrap_or(0.0);
    let predicted = resident + estimate.total();
    let p = if predicted.is_finite() {
        predicted.min(u64::MAX as f64) as u64
    } else {
        u64::MAX
    };
    if PREDICTED.fetch_max(p, Ordering::Relaxed) < p {
        let mut parts = vec![PredictedPart {
            what: format!("resident at {stage}"),
            bytes: resident,
        }];
        parts.extend(estimate.parts.iter().map(|q| PredictedPart {
            what: q.what.to_string(),
            bytes: q.bytes,
        }));
        if let Ok(mut kept) = PREDICTED_PARTS.lock() {
            *kept = parts;
        }
    }
    let b = budget();
    match b.limit_bytes {
        Some(limit) if predicted > limit || !predicted.is_finite() => {
            Err(AppError::Memory(Box::new(MemoryRefusal {
                stage,
                predicted: format_bytes(predicted),
                estimate: estimate.to_string(),
                resident: format_bytes(resident),
                limit: format_bytes(limit),
                limit_source: match b.source {
                    LimitSource::Flag => "--max-memory",
                    _ => "available on this machine; --max-memory sets another limit",
                },
                hint,
            })))
        }
        _ => Ok(()),
    }
}

/// A stage refused for memory: what it would take and what to change.
#[derive(Debug, thiserror::Error)]
#[error(
    "{stage} would need about {estimate} on top of the {resident} in use, a peak of \
     {predicted}: more than the {limit} {limit_source}; {hint}"
)]
pub struct MemoryRefusal {
    /// The stage refused.
    pub stage: &'static str,
    /// The predicted peak (resident + estimate).
    pub predicted: String,
    /// The stage's estimate with its parts.
    pub estimate: String,
    /// The resident size at the check.
    pub resident: String,
    /// The limit.
    pub limit: String,
    /// Where the limit comes from.
    pub limit_source: &'static str,
    /// What to change.
    pub hint: &'static str,
}

/// The bytes the run may still allocate: the limit less the resident size
/// now (`None`: no limit).
pub fn room() -> Option<f64> {
    budget()
        .limit_bytes
        .map(|l| (l - resident_bytes().unwrap_or(0.0)).max(0.0))
}

/// Records a prediction made elsewhere (a library's own check), so the
/// report's predicted peak covers it.
pub fn record(predicted_bytes: f64) {
    if predicted_bytes.is_finite() && predicted_bytes >= 0.0 {
        let p = predicted_bytes.min(u64::MAX as f64) as u64;
        if PREDICTED.fetch_max(p, Ordering::Relaxed) < p
            && let Ok(mut kept) = PREDICTED_PARTS.lock()
        {
            *kept = vec![PredictedPart {
                what: "a library's own check".to_string(),
                bytes: predicted_bytes,
            }];
        }
    }
}

/// One part of the highest predicted peak: the resident size when it was
/// checked, or a part of the stage's estimate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PredictedPart {
    /// What it is (`"resident at STAGE"`, or the estimate's part).
    pub what: String,
    /// Bytes.
    pub bytes: f64,
}

/// What a report says of memory.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MemoryReport {
    /// The highest predicted peak of the run (resident + a stage's
    /// estimate), bytes.
    pub predicted_peak_bytes: u64,
    /// The measured peak resident size so far (`VmHWM`), bytes, where the
    /// system tells it.
    pub peak_bytes: Option<u64>,
    /// The limit, bytes (none: no limit known).
    pub limit_bytes: Option<u64>,
    /// Where the limit came from.
    pub limit_source: LimitSource,
    /// The parts of the highest predicted peak (the resident size at its
    /// check, then the stage's estimate), to compare with `peak_bytes`;
    /// empty when the prediction was recorded without parts (always
    /// written, so every report has the same keys; read as empty from a
    /// report without it).
    #[serde(default)]
    pub predicted_parts: Vec<PredictedPart>,
}

impl MemoryReport {
    /// A prediction of `bytes` alone (0 when not finite or negative),
    /// without a budget or a measured peak: Python's runs, which have no
    /// budget of their own.
    pub fn predicted(bytes: f64) -> Self {
        MemoryReport {
            predicted_peak_bytes: if bytes.is_finite() && bytes > 0.0 {
                bytes as u64
            } else {
                0
            },
            peak_bytes: None,
            limit_bytes: None,
            limit_source: LimitSource::Unknown,
            predicted_parts: Vec::new(),
        }
    }

    /// [`MemoryReport::predicted`] of the estimate's total, with its parts
    /// as [`MemoryReport::predicted_parts`].
    pub fn predicted_from(estimate: &MemoryEstimate) -> Self {
        let mut report = Self::predicted(estimate.total());
        report.predicted_parts = estimate
            .parts
            .iter()
            .map(|q| PredictedPart {
                what: q.what.to_string(),
                bytes: q.bytes,
            })
            .collect();
        report
    }
}

/// The memory section of a report, now.
pub fn report() -> MemoryReport {
    let b = budget();
    MemoryReport {
        predicted_peak_bytes: PREDICTED.load(Ordering::Relaxed),
        peak_bytes: peak_resident_bytes().map(|x| x as u64),
        limit_bytes: b.limit_bytes.map(|x| x as u64),
        limit_source: b.source,
        predicted_parts: PREDICTED_PARTS
            .lock()
            .map(|p| p.clone())
            .unwrap_or_default(),
    }
}

/// Parses a size: bytes, or a number with a binary unit `K`, `M`, `G`,
/// `T` (also `KB`, `KiB`, ...; case-insensitive; `1.5G` is 1.5 x 2^30).
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t.find(|c: char| c.is_ascii_alphabetic()).unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let value: f64 = num
        .trim()
        .parse()
        .map_err(|_| format!("'{text}' is not a size (e.g. 4G, 512M, 1.5GiB)"))?;
    let shift = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 0,
        "k" | "kb" | "kib" => 10,
        "m" | "mb" | "mib" => 20,
        "g" | "gb" | "gib" => 30,
        "t" | "tb" | "tib" => 40,
        u => return Err(format!("unknown unit '{u}' in '{text}' (use K, M, G or T)")),
    };
    let bytes = value * (1u64 << shift) as f64;
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("'{text}' is not a size > 0"));
    }
    Ok(bytes as u64)
}

/// A field of `/proc/self/status` in bytes (`VmRSS`, `VmHWM`).
fn status_bytes(field: &str) -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    kib_field(&s, field)
}

/// `name:   123 kB` in a `/proc` text, as bytes.
fn kib_field(text: &str, name: &str) -> Option<f64> {
    let line = text.lines().find(|l| l.split(':').next() == Some(name))?;
    let kib: f64 = line
        .split(':')
        .nth(1)?
        .split_whitespace()
        .next()?
        .parse()
        .ok()?;
    Some(kib * 1024.0)
}

/// The process's resident size now, bytes.
pub fn resident_bytes() -> Option<f64> {
    status_bytes("VmRSS")
}

/// The highest `VmHWM` seen before a [`reset_peak`], bytes.
static PEAK_BEFORE_RESET: AtomicU64 = AtomicU64::new(0);

/// The process's peak resident size so far, bytes (a [`reset_peak`] does
/// not lower it).
pub fn peak_resident_bytes() -> Option<f64> {
    status_bytes("VmHWM").map(|p| p.max(PEAK_BEFORE_RESET.load(Ordering::Relaxed) as f64))
}

/// Resets the kernel's peak resident size (`VmHWM`) to the resident size
/// now (`5` written to `/proc/self/clear_refs`, Linux 4.0 and later), so
/// that [`peak_since_reset`] measures one stage; [`peak_resident_bytes`]
/// keeps the peak before. False where the system does not allow it.
pub fn reset_peak() -> bool {
    if let Some(p) = status_bytes("VmHWM") {
        PEAK_BEFORE_RESET.fetch_max(p as u64, Ordering::Relaxed);
    }
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// The peak resident size since the last [`reset_peak`] (`VmHWM`), bytes.
pub fn peak_since_reset() -> Option<f64> {
    status_bytes("VmHWM")
}

/// A number in a cgroup file (`max` and unreadable: none).
fn cgroup_number(path: &str) -> Option<f64> {
    let t = std::fs::read_to_string(path).ok()?;
    let v: f64 = t.trim().parse().ok()?;
    // v1 reports "no limit" as a huge number
    (v < 1e18).then_some(v)
}

/// The memory this process may still take: the least of `MemAvailable`
/// and the cgroup's room, plus what the process holds already (its
/// resident size counts against the limit in [`check`]).
fn available_bytes() -> Option<f64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| kib_field(&t, "MemAvailable"));
    let v2 = cgroup_number("/sys/fs/cgroup/memory.max").and_then(|max| {
        cgroup_number("/sys/fs/cgroup/memory.current").map(|cur| (max - cur).max(0.0))
    });
    let v1 = cgroup_number("/sys/fs/cgroup/memory/memory.limit_in_bytes").and_then(|max| {
        cgroup_number("/sys/fs/cgroup/memory/memory.usage_in_bytes").map(|cur| (max - cur).max(0.0))
    });
    let room = [meminfo, v2, v1].into_iter().flatten().reduce(f64::min)?;
    Some(room + resident_bytes().unwrap_or(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_binary_units() {
        assert_eq!(parse_size("4G"), Ok(4 << 30));
        assert_eq!(parse_size("512m"), Ok(512 << 20));
        assert_eq!(parse_size("1.5GiB"), Ok(3 << 29));
        assert_eq!(parse_size("2048"), Ok(2048));
        assert_eq!(parse_size(" 3 KB "), Ok(3072));
        for bad in ["", "G", "-1G", "0", "4X", "nanG", "1e30T"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn proc_fields_read_as_bytes() {
        let t = "Name:\tunfold\nVmHWM:\t  2048 kB\nVmRSS:\t  1024 kB\n";
        assert_eq!(kib_field(t, "VmRSS"), Some(1024.0 * 1024.0));
        assert_eq!(kib_field(t, "VmHWM"), Some(2048.0 * 1024.0));
        assert_eq!(kib_field(t, "Vm"), None);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn this_process_has_a_resident_size_and_peak() {
        let r = resident_bytes().unwrap();
        let p = peak_resident_bytes().unwrap();
        assert!(r > 0.0 && p >= r * 0.5, "{r} {p}");
        assert!(available_bytes().is_some());
    }
}

//! Quality gates: after each stage of a pipeline, a measured value that a
//! wrong result cannot have (a side split whose eigensolver stopped early, a
//! solve that never moved, a basal rim the landmarks disagree with, a
//! lopsided segment table). Each gate is recorded with its value, and
//! `report.json` lists them all (`gates`), passed or not.
//!
//! A gate that fails either stops the run with a [`GateError`], one line
//! naming the value, what a right result has and the fix
//! ([`Gates::check`]), or, where a sound fallback exists, is recorded with
//! the fallback the pipeline took ([`Gates::fallback`]).
//!
//! A gate passes when its value meets its [`Requirement`]
//! (`Requirement::holds`: finite, and in range); a NaN never passes.

use crate::Requirement;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use thiserror::Error;

/// One gate as `report.json` lists it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Gate {
    /// `stage.check`, e.g. `sides.eigensolver_residual`.
    pub name: Cow<'static, str>,
    /// The value measured (`null` when it could not be measured).
    #[serde(with = "unfold_mesh::nan_as_null")]
    pub value: f64,
    /// What a right result has, e.g. `in [0.2, 5]`.
    pub requirement: String,
    /// Whether the value meets it.
    pub passed: bool,
    /// What the pipeline did instead when the gate failed and a sound
    /// fallback exists (absent otherwise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fallback: Option<Cow<'static, str>>,
}

/// A gate failed and no sound fallback exists: "`name` is `value`, a right
/// result has `requirement`: `fix`".
#[derive(Debug, Clone, PartialEq, Error)]
#[error("quality gate {name}: {value} is not {requirement}; {fix}")]
pub struct GateError {
    /// The gate, `stage.check`.
    pub name: Cow<'static, str>,
    /// The value measured.
    pub value: f64,
    /// What a right result has.
    pub requirement: Requirement,
    /// What the user can do: the flag or the repair that helps.
    pub fix: Cow<'static, str>,
}

/// The gates of one run, in the order they were checked.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Gates(pub Vec<Gate>);

impl Gates {
    /// No gates yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Records the gate `name` and returns whether `value` meets
    /// `requirement`.
    fn record(
        &mut self,
        name: impl Into<Cow<'static, str>>,
        value: f64,
        requirement: Requirement,
        fallback: Option<Cow<'static, str>>,
    ) -> bool {
        let passed = requirement.holds(value);
        self.0.push(Gate {
            name: name.into(),
            value,
            requirement: requirement.to_string(),
            passed,
            fallback: if passed { None } else { fallback },
        });
        passed
    }

    /// Records the gate and fails when `value` does not meet `requirement`.
    ///
    /// # Errors
    /// [`GateError`] naming the gate, its value, the requirement and `fix`.
    pub fn check(
        &mut self,
        name: impl Into<Cow<'static, str>>,
        value: f64,
        requirement: Requirement,
        fix: impl Into<Cow<'static, str>>,
    ) -> Result<(), GateError> {
        let name = name.into();
        if self.record(name.clone(), value, requirement, None) {
            Ok(())
        } else {
            Err(GateError {
                name,
                value,
                requirement,
                fix: fix.into(),
            })
        }
    }

    /// Records the gate; when `value` does not meet `requirement`, records
    /// `fallback` as what the pipeline does instead. Returns whether the gate
    /// passed (the caller takes the fallback when it did not).
    pub fn fallback(
        &mut self,
        name: impl Into<Cow<'static, str>>,
        value: f64,
        requirement: Requirement,
        fallback: impl Into<Cow<'static, str>>,
    ) -> bool {
        self.record(name, value, requirement, Some(fallback.into()))
    }

    /// Appends another run's gates (a stage's own list) after these.
    pub fn extend(&mut self, other: Gates) {
        self.0.extend(other.0);
    }

    /// The gate named `name`, if it was checked.
    pub fn get(&self, name: &str) -> Option<&Gate> {
        self.0.iter().find(|g| g.name == name)
    }

    /// Whether every recorded gate passed (fallbacks count as failed).
    pub fn all_passed(&self) -> bool {
        self.0.iter().all(|g| g.passed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_failed_check_is_recorded_and_names_the_fix() {
        let mut gates = Gates::new();
        assert!(
            gates
                .check("sides.ratio", 2.0, Requirement::Within(0.2, 5.0), "x")
                .is_ok()
        );
        let e = gates
            .check(
                "sides.ratio",
                250.0,
                Requirement::Within(0.2, 5.0),
                "mesh the mask finer",
            )
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "quality gate sides.ratio: 250 is not in [0.2, 5]; mesh the mask finer"
        );
        assert_eq!(gates.0.len(), 2);
        assert!(gates.0[0].passed && !gates.0[1].passed);
        assert!(!gates.all_passed());
    }

    #[test]
    fn a_fallback_is_recorded_only_when_taken() {
        let mut gates = Gates::new();
        assert!(gates.fallback("a", 1.0, Requirement::Positive, "used b"));
        assert!(!gates.fallback("b", -1.0, Requirement::Positive, "used c"));
        assert_eq!(gates.get("a").unwrap().fallback, None);
        assert_eq!(gates.get("b").unwrap().fallback.as_deref(), Some("used c"));
    }

    #[test]
    fn nan_never_passes_and_reads_back() {
        let mut gates = Gates::new();
        assert!(
            gates
                .check("x", f64::NAN, Requirement::NonNegative, "f")
                .is_err()
        );
        let json = serde_json::to_string(&gates).unwrap();
        assert!(json.contains("\"value\":null"), "{json}");
        let back: Gates = serde_json::from_str(&json).unwrap();
        assert!(back.0[0].value.is_nan() && !back.0[0].passed);
    }

    proptest! {
        #[test]
        fn passed_is_the_requirement(v in -10.0f64..10.0, lo in -5.0f64..0.0, hi in 0.0f64..5.0) {
            let mut gates = Gates::new();
            let ok = gates.check("g", v, Requirement::Within(lo, hi), "f").is_ok();
            prop_assert_eq!(ok, (lo..=hi).contains(&v));
            prop_assert_eq!(gates.0[0].passed, ok);
            let json = serde_json::to_string(&gates).unwrap();
            let back: Gates = serde_json::from_str(&json).unwrap();
            prop_assert_eq!(back, gates);
        }
    }
}

//! The design of a voxelwise general linear model: the regressors coded
//! into a full model `M = [Z | X]` and its orthonormal basis.
//!
//! Coding (ALGORITHMS 5.1): an intercept; a categorical regressor with `g`
//! sorted levels becomes `g - 1` indicator columns (the first level is the
//! reference); a continuous regressor is centred. `Z` holds the nuisance
//! columns (intercept, then the covariates in their order), `X` the columns
//! of the regressor of interest. The basis `Q = [Q_Z | Q_X]` comes from
//! Gram-Schmidt on the columns of `[Z | X]` in that order (each column
//! orthogonalized twice), so `Q_Z` spans `Z` and `Q_X` spans the part of
//! `X` orthogonal to `Z`.

use serde::Serialize;

use super::error::GlmError;

/// The values of one regressor, one per subject, in subject order.
#[derive(Debug, Clone, PartialEq)]
pub enum RegressorValues {
    /// Group labels; the levels are the distinct labels, sorted.
    Categorical(Vec<String>),
    /// A number per subject (an age, a gestational week, a volume).
    Continuous(Vec<f64>),
}

/// A named regressor (a column of the study table).
#[derive(Debug, Clone, PartialEq)]
pub struct Regressor {
    /// Its name (the column's header), used in messages and descriptions.
    pub name: String,
    /// Its values, one per subject.
    pub values: RegressorValues,
}

/// Which statistic a design tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum StatisticKind {
    /// Student's t (signed): a continuous interest or two groups.
    T,
    /// The partial F of the interest given the nuisance: three or more groups.
    F,
}

/// The interest as the design keeps it for descriptions.
#[derive(Debug, Clone, PartialEq)]
enum Interest {
    Groups {
        levels: Vec<String>,
        counts: Vec<usize>,
    },
    Continuous,
}

/// A coded design: the full model's orthonormal basis and what it tests.
///
/// Rows are subjects, in the same order as the regressors' values and as
/// the rows of the `y` given to
/// [`permutation_test`](super::permutation_test).
#[derive(Debug, Clone, PartialEq)]
pub struct Design {
    subjects: usize,
    interest_name: String,
    interest: Interest,
    covariate_names: Vec<String>,
    kind: StatisticKind,
    /// Columns of `Z` (intercept and covariates).
    nuisance_columns: usize,
    /// Columns of `X` (the interest).
    interest_columns: usize,
    /// `Q = [Q_Z | Q_X]`, `subjects x (nuisance + interest)`, column-major.
    basis: Vec<f64>,
    /// `M = [Z | X]` as coded, same shape and layout (for tests and checks).
    model: Vec<f64>,
    /// Level index of each subject when the interest is categorical.
    labels: Option<Vec<usize>>,
}

/// A regressor coded into columns.
struct Coded {
    columns: Vec<Vec<f64>>,
    groups: Option<(Vec<String>, Vec<usize>, Vec<usize>)>,
}

/// Relative norm under which a Gram-Schmidt residual counts as zero.
const RANK_TOLERANCE: f64 = 1e-9;

fn code(regressor: &Regressor, n: usize) -> Result<Coded, GlmError> {
    let name = &regressor.name;
    match &regressor.values {
        RegressorValues::Continuous(values) => {
            if values.len() != n {
                return Err(GlmError::RegressorLength {
                    name: name.clone(),
                    expected: n,
                    found: values.len(),
                });
            }
            if let Some(row) = values.iter().position(|v| !v.is_finite()) {
                return Err(GlmError::NonFiniteRegressor {
                    name: name.clone(),
                    row,
                });
            }
            let mean = values.iter().sum::<f64>() / n as f64;
            Ok(Coded {
                columns: vec![values.iter().map(|v| v - mean).collect()],
                groups: None,
            })
        }
        RegressorValues::Categorical(values) => {
            if values.len() != n {
                return Err(GlmError::RegressorLength {
                    name: name.clone(),
                    expected: n,
                    found: values.len(),
                });
            }
            if let Some(row) = values.iter().position(|v| v.trim().is_empty()) {
                return Err(GlmError::MissingLevel {
                    name: name.clone(),
                    row,
                });
            }
            let mut levels: Vec<String> = values.clone();
            levels.sort();
            levels.dedup();
            if levels.len() < 2 {
                return Err(GlmError::SingleLevel {
                    name: name.clone(),
                    level: levels.first().cloned().unwrap_or_default(),
                });
            }
            let labels: Vec<usize> = values
                .iter()
                .map(|v| levels.binary_search(v).unwrap_or_default())
                .collect();
            let mut counts = vec![0usize; levels.len()];
            for &l in &labels {
                counts[l] += 1;
            }
            let columns = (1..levels.len())
                .map(|level| {
                    labels
                        .iter()
                        .map(|&l| f64::from(u8::from(l == level)))
                        .collect()
                })
                .collect();
            Ok(Coded {
                columns,
                groups: Some((levels, counts, labels)),
            })
        }
    }
}

/// Orthogonalizes `column` against the unit columns of `basis` (twice, so
/// the result is orthogonal to working precision). Returns its norm
/// before normalization and the normalized column.
fn orthogonalize(basis: &[Vec<f64>], mut column: Vec<f64>) -> (f64, Vec<f64>) {
    for _ in 0..2 {
        for q in basis {
            let dot: f64 = q.iter().zip(&column).map(|(a, b)| a * b).sum();
            for (c, a) in column.iter_mut().zip(q) {
                *c -= dot * a;
            }
        }
    }
    let norm = column.iter().map(|c| c * c).sum::<f64>().sqrt();
    if norm > 0.0 {
        for c in &mut column {
            *c /= norm;
        }
    }
    (norm, column)
}

impl Design {
    /// Codes a design. `interest` is the tested regressor, `covariates` the
    /// nuisance regressors; every regressor has one value per subject, in
    /// the same subject order.
    ///
    /// Errors: a regressor of another length ([`GlmError::RegressorLength`]),
    /// a non-finite continuous value, an empty categorical value, a
    /// categorical regressor with one level, a continuous interest that does
    /// not vary, `n <= columns of M` ([`GlmError::TooFewSubjects`]), and a
    /// regressor collinear with the ones before it (intercept, covariates in
    /// order, interest) ([`GlmError::RankDeficient`]).
    pub fn new(interest: Regressor, covariates: Vec<Regressor>) -> Result<Design, GlmError> {
        let n = match &interest.values {
            RegressorValues::Categorical(v) => v.len(),
            RegressorValues::Continuous(v) => v.len(),
        };
        let coded_interest = code(&interest, n)?;
        if coded_interest.groups.is_none() {
            let spread = coded_interest.columns[0].iter().map(|v| v * v).sum::<f64>();
            let scale = match &interest.values {
                RegressorValues::Continuous(v) => v.iter().map(|v| v * v).sum::<f64>(),
                RegressorValues::Categorical(_) => 0.0,
            };
            if n < 2 || spread <= RANK_TOLERANCE * RANK_TOLERANCE * scale || spread == 0.0 {
                return Err(GlmError::ConstantInterest {
                    name: interest.name.clone(),
                });
            }
        }
        let coded_covariates = covariates
            .iter()
            .map(|c| code(c, n))
            .collect::<Result<Vec<_>, _>>()?;

        let nuisance_columns = 1 + coded_covariates
            .iter()
            .map(|c| c.columns.len())
            .sum::<usize>();
        let interest_columns = coded_interest.columns.len();
        let p = nuisance_columns + interest_columns;
        if n <= p {
            return Err(GlmError::TooFewSubjects {
                subjects: n,
                columns: p,
            });
        }

        // [Z | X] in order, each column with the regressor it came from.
        let mut ordered: Vec<(&str, Vec<f64>)> = vec![("intercept", vec![1.0; n])];
        for (regressor, coded) in covariates.iter().zip(&coded_covariates) {
            for column in &coded.columns {
                ordered.push((regressor.name.as_str(), column.clone()));
            }
        }
        for column in &coded_interest.columns {
            ordered.push((interest.name.as_str(), column.clone()));
        }
        let mut basis: Vec<Vec<f64>> = Vec::with_capacity(p);
        let mut model = Vec::with_capacity(n * p);
        for (name, column) in ordered {
            let original = column.iter().map(|c| c * c).sum::<f64>().sqrt();
            model.extend_from_slice(&column);
            let (norm, unit) = orthogonalize(&basis, column);
            if norm <= RANK_TOLERANCE * original || norm == 0.0 {
                return Err(GlmError::RankDeficient {
                    regressor: name.to_string(),
                });
            }
            basis.push(unit);
        }

        let (interest_kind, labels) = match coded_interest.groups {
            Some((levels, counts, labels)) => (Interest::Groups { levels, counts }, Some(labels)),
            None => (Interest::Continuous, None),
        };
        let kind = if interest_columns == 1 {
            StatisticKind::T
        } else {
            StatisticKind::F
        };
        Ok(Design {
            subjects: n,
            interest_name: interest.name,
            interest: interest_kind,
            covariate_names: covariates.into_iter().map(|c| c.name).collect(),
            kind,
            nuisance_columns,
            interest_columns,
            basis: basis.into_iter().flatten().collect(),
            model,
            labels,
        })
    }

    /// The number of subjects (rows).
    pub fn subjects(&self) -> usize {
        self.subjects
    }

    /// [`StatisticKind::T`] for a continuous interest or two groups,
    /// [`StatisticKind::F`] for three or more groups.
    pub fn kind(&self) -> StatisticKind {
        self.kind
    }

    /// The sorted levels of a categorical interest (the first is the
    /// reference); `None` for a continuous interest.
    pub fn levels(&self) -> Option<&[String]> {
        match &self.interest {
            Interest::Groups { levels, .. } => Some(levels),
            Interest::Continuous => None,
        }
    }

    /// `(k, n - p)`: the rank `k` of the contrast (the interest's columns:
    /// 1 for t, `g - 1` for `g` groups) and the residual degrees of freedom
    /// `n - rank(M)`, with `p = rank(M)` the columns of the full model.
    pub fn degrees_of_freedom(&self) -> (f64, f64) {
        (
            self.interest_columns as f64,
            (self.subjects - self.nuisance_columns - self.interest_columns) as f64,
        )
    }

    /// One line: the statistic, what it contrasts, the groups and their
    /// sizes, and the covariates, e.g.
    /// `t: B - A (2 groups: A 10, B 12), covariates age`.
    pub fn describe(&self) -> String {
        let mut line = match &self.interest {
            Interest::Groups { levels, counts } => {
                let groups = levels
                    .iter()
                    .zip(counts)
                    .map(|(l, c)| format!("{l} {c}"))
                    .collect::<Vec<_>>()
                    .join(", ");
                match self.kind {
                    StatisticKind::T => {
                        format!("t: {} - {} (2 groups: {groups})", levels[1], levels[0])
                    }
                    StatisticKind::F => format!(
                        "F: {} ({} groups: {groups})",
                        self.interest_name,
                        levels.len()
                    ),
                }
            }
            Interest::Continuous => {
                format!(
                    "t: {} (continuous, {} subjects)",
                    self.interest_name, self.subjects
                )
            }
        };
        if !self.covariate_names.is_empty() {
            line.push_str(", covariates ");
            line.push_str(&self.covariate_names.join(", "));
        }
        line
    }

    /// `Q = [Q_Z | Q_X]`, `n x p` column-major.
    pub(crate) fn basis(&self) -> &[f64] {
        &self.basis
    }

    /// The coded full model `M = [Z | X]`, `n x p` column-major: the
    /// intercept, the covariates' columns in order, then the interest's
    /// columns (ALGORITHMS 5.1).
    pub fn model_matrix(&self) -> &[f64] {
        &self.model
    }

    /// Columns of `Z` (`q`, intercept included).
    pub(crate) fn nuisance_columns(&self) -> usize {
        self.nuisance_columns
    }

    /// Columns of `X` (`k`).
    pub(crate) fn interest_columns(&self) -> usize {
        self.interest_columns
    }

    /// The level of each subject when the interest is categorical and the
    /// design has no covariate: then only the relabeling of subjects into
    /// groups matters, and exhaustive enumeration counts distinct
    /// relabelings.
    pub(crate) fn relabeling_only(&self) -> Option<(&[usize], usize)> {
        match (&self.labels, &self.interest) {
            (Some(labels), Interest::Groups { levels, .. }) if self.covariate_names.is_empty() => {
                Some((labels, levels.len()))
            }
            _ => None,
        }
    }
}

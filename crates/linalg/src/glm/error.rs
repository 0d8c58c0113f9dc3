//! The error type of the voxelwise general linear model.

use thiserror::Error;

/// Everything that can go wrong building a [`Design`](super::Design) or
/// testing it. Each variant holds the names and numbers that explain the
/// failure.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum GlmError {
    /// The model has as many columns as there are subjects, or more: no
    /// degree of freedom is left for the residual variance.
    #[error(
        "{subjects} subjects are too few for a model with {columns} columns (intercept, interest, covariates): \
         at least {} are needed",
        columns + 1
    )]
    TooFewSubjects {
        /// Subjects (rows of the design).
        subjects: usize,
        /// Columns of the full model `M = [Z | X]`, its rank when it has full rank.
        columns: usize,
    },
    /// A categorical regressor takes a single value: there is no group to
    /// compare with.
    #[error("regressor {name} has one level ({level}) over all subjects: it needs two or more")]
    SingleLevel {
        /// The regressor.
        name: String,
        /// Its only level.
        level: String,
    },
    /// A categorical regressor has no level for one subject (an empty
    /// string), so the subject belongs to no group.
    #[error("regressor {name} has no level for subject row {row} (an empty value)")]
    MissingLevel {
        /// The regressor.
        name: String,
        /// The subject's row (0-based).
        row: usize,
    },
    /// A regressor does not have one value per subject.
    #[error("regressor {name} has {found} values for {expected} subjects")]
    RegressorLength {
        /// The regressor.
        name: String,
        /// The number of subjects (the interest's length).
        expected: usize,
        /// The number of values it has.
        found: usize,
    },
    /// A regressor's columns lie in the span of the intercept and of the
    /// regressors before it (covariates in their order, then the interest).
    #[error(
        "regressor {regressor} is collinear with the intercept and the regressors before it \
         (the design is rank-deficient: drop or change {regressor})"
    )]
    RankDeficient {
        /// The regressor whose column adds nothing new.
        regressor: String,
    },
    /// A value of `y` is NaN or infinite.
    #[error("the value of column {column}, subject {subject} is not finite")]
    NonFiniteValue {
        /// The column of `y` (a voxel or a segment, 0-based).
        column: usize,
        /// The subject (row, 0-based).
        subject: usize,
    },
    /// `y`'s length is not a whole number of columns of `subjects` values.
    #[error("{len} values are not a whole number of columns of {subjects} subjects")]
    LengthNotMultiple {
        /// The length of `y`.
        len: usize,
        /// The number of subjects.
        subjects: usize,
    },
    /// `y` has no column to test.
    #[error("no column to test (y is empty)")]
    NoColumns,
    /// Zero permutations were asked for (the identity alone needs one).
    #[error("zero permutations asked for: give at least 1 (1000 is usual)")]
    ZeroPermutations,
    /// More permutations were asked for than the test keeps maxima for
    /// (each relabeling keeps one maximum per worker thread).
    #[error(
        "{asked} permutations asked for: at most {max} are run (10000 is plenty for p down to 1e-4)"
    )]
    TooManyPermutations {
        /// The number asked for.
        asked: usize,
        /// The largest number accepted.
        max: usize,
    },
    /// A continuous regressor has a NaN or infinite value.
    #[error("regressor {name} has a value that is not finite at subject row {row}")]
    NonFiniteRegressor {
        /// The regressor.
        name: String,
        /// The subject's row (0-based).
        row: usize,
    },
    /// A continuous interest takes the same value for every subject.
    #[error("regressor {name} does not vary over the subjects: there is no effect to test")]
    ConstantInterest {
        /// The regressor.
        name: String,
    },
}

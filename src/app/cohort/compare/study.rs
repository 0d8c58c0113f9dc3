//! The comparison being run: its settings, the column's kind, the
//! subjects left out, and the design and test of one analysis.

use super::*;

/// The comparison being run: settings, the column's kind, what was left
/// out.
pub(super) struct Study<'a> {
    pub(super) settings: &'a CompareSettings,
    pub(super) kind: ColumnKind,
    pub(super) left_out: Vec<LeftOut>,
    pub(super) dir: PathBuf,
}

impl Study<'_> {
    /// Notes `id` left out for `why` (once).
    pub(super) fn leave_out(&mut self, id: &str, why: String) {
        let l = LeftOut {
            id: id.to_string(),
            why,
        };
        if !self.left_out.contains(&l) {
            self.left_out.push(l);
        }
    }

    /// The rows with a value in the column and every covariate; the others
    /// left out and named.
    pub(super) fn eligible<'r>(&mut self, rows: Vec<&'r SubjectRow>) -> Vec<&'r SubjectRow> {
        let mut keep = Vec::with_capacity(rows.len());
        for r in rows {
            let empty = std::iter::once(&self.settings.column)
                .chain(&self.settings.covariates)
                .find(|c| r.covariates.get(*c).is_none_or(|v| v.trim().is_empty()));
            match empty {
                Some(c) => self.leave_out(&r.id, format!("its '{c}' cell is empty")),
                None => keep.push(r),
            }
        }
        keep
    }

    /// The regressors of `rows` (all eligible).
    pub(super) fn regressors(&self, rows: &[&SubjectRow]) -> (Regressor, Vec<Regressor>) {
        let cell = |r: &SubjectRow, c: &str| r.covariates.get(c).cloned().unwrap_or_default();
        let column = &self.settings.column;
        let interest = Regressor {
            name: column.clone(),
            values: match self.kind {
                ColumnKind::Categorical => RegressorValues::Categorical(
                    rows.iter()
                        .map(|r| cell(r, column).trim().to_string())
                        .collect(),
                ),
                ColumnKind::Continuous => RegressorValues::Continuous(
                    rows.iter()
                        .map(|r| number(&cell(r, column)).unwrap_or(f64::NAN))
                        .collect(),
                ),
            },
        };
        let covariates = self
            .settings
            .covariates
            .iter()
            .map(|c| Regressor {
                name: c.clone(),
                values: RegressorValues::Continuous(
                    rows.iter()
                        .map(|r| number(&cell(r, c)).unwrap_or(f64::NAN))
                        .collect(),
                ),
            })
            .collect();
        (interest, covariates)
    }

    /// The groups of `rows` and their sizes (none for a continuous column).
    pub(super) fn groups(&self, rows: &[&SubjectRow]) -> BTreeMap<String, usize> {
        let mut g = BTreeMap::new();
        if self.kind == ColumnKind::Categorical {
            for r in rows {
                let v = r.covariates.get(&self.settings.column);
                *g.entry(v.map_or("", |v| v.trim()).to_string()).or_insert(0) += 1;
            }
        }
        g
    }

    /// Fits and tests `y` (`rows.len()` x columns, column-major) for the
    /// analysis `what`.
    pub(super) fn test(
        &self,
        what: &str,
        rows: &[&SubjectRow],
        y: &[f64],
    ) -> Result<(Design, TestResult), AppError> {
        let analysis = format!(
            "--compare {}: {what} over {} subjects",
            self.settings.column,
            rows.len()
        );
        let wrap = |source| AppError::Compare {
            analysis: analysis.clone(),
            source,
        };
        let (interest, covariates) = self.regressors(rows);
        let design = Design::new(interest, covariates).map_err(wrap)?;
        let settings = PermutationSettings {
            permutations: self.settings.permutations,
            seed: self.settings.seed,
        };
        let result = permutation_test(&design, y, &settings).map_err(wrap)?;
        Ok((design, result))
    }

    /// The summary of a test.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn analysis(
        &self,
        organ: &str,
        name: &str,
        rows: &[&SubjectRow],
        design: &Design,
        result: &TestResult,
        files: Vec<String>,
    ) -> Analysis {
        Analysis {
            organ: organ.to_string(),
            name: name.to_string(),
            design: design.describe(),
            statistic: result.kind,
            groups: self.groups(rows),
            subjects: rows.iter().map(|r| r.id.clone()).collect(),
            permutations: result.permutations,
            exhaustive: result.exhaustive,
            degrees_of_freedom: result.degrees_of_freedom,
            tested: result.statistic.len(),
            min_p_fwe: result.p_fwe.iter().copied().fold(1.0, f64::min),
            significant: result.p_fwe.iter().filter(|&&p| p < ALPHA).count(),
            files,
        }
    }
}

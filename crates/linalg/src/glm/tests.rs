//! Tests of the GLM: the statistics against a direct least-squares fit,
//! Freedman-Lane against plain permutation, invariances, exhaustive
//! enumeration against brute force, a planted effect, the null rate, the
//! errors and determinism.

use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;

use super::shuffles::Shuffles;
use super::*;
use crate::test_support::Rng;

fn normal(rng: &mut Rng) -> f64 {
    let u = rng.f64().max(1e-300);
    let v = rng.f64();
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

fn groups(labels: &[usize]) -> Regressor {
    Regressor {
        name: "group".into(),
        values: RegressorValues::Categorical(
            labels
                .iter()
                .map(|&l| ["A", "B", "C", "D"][l].to_string())
                .collect(),
        ),
    }
}

fn continuous(name: &str, values: Vec<f64>) -> Regressor {
    Regressor {
        name: name.into(),
        values: RegressorValues::Continuous(values),
    }
}

/// Balanced-ish labels 0..g over n subjects, shuffled.
fn labels(n: usize, g: usize, rng: &mut Rng) -> Vec<usize> {
    let mut l: Vec<usize> = (0..n).map(|i| i % g).collect();
    for i in (1..n).rev() {
        l.swap(i, rng.below(i + 1));
    }
    l
}

/// The columns a regressor contributes, coded independently of the
/// library: indicators of every level but the smallest, raw continuous
/// values (centring changes no statistic).
fn columns_of(r: &Regressor) -> Vec<Vec<f64>> {
    match &r.values {
        RegressorValues::Continuous(v) => vec![v.clone()],
        RegressorValues::Categorical(v) => {
            let mut levels = v.clone();
            levels.sort();
            levels.dedup();
            levels[1..]
                .iter()
                .map(|level| {
                    v.iter()
                        .map(|x| if x == level { 1.0 } else { 0.0 })
                        .collect()
                })
                .collect()
        }
    }
}

fn matrix(n: usize, columns: &[Vec<f64>]) -> DMatrix<f64> {
    DMatrix::from_fn(n, columns.len(), |i, j| columns[j][i])
}

/// Residual sum of squares and coefficients of `y` on `m` (SVD solve).
fn least_squares(m: &DMatrix<f64>, y: &DVector<f64>) -> (f64, DVector<f64>) {
    let b = m.clone().svd(true, true).solve(y, 1e-12).unwrap();
    ((y - m * &b).norm_squared(), b)
}

/// The t (interest's single column, last) or partial F of the interest
/// given the nuisance, by direct fits of the full and reduced models.
fn direct_statistic(interest: &Regressor, covariates: &[Regressor], y: &[f64]) -> (f64, f64) {
    let n = y.len();
    let mut nuisance = vec![vec![1.0; n]];
    for c in covariates {
        nuisance.extend(columns_of(c));
    }
    let x = columns_of(interest);
    let mut full = nuisance.clone();
    full.extend(x.clone());
    let m = matrix(n, &full);
    let z = matrix(n, &nuisance);
    let yv = DVector::from_column_slice(y);
    let (rss, b) = least_squares(&m, &yv);
    let (rss_z, _) = least_squares(&z, &yv);
    let p = full.len();
    let k = x.len();
    let df = (n - p) as f64;
    let s2 = rss / df;
    let f = ((rss_z - rss) / k as f64) / s2;
    let t = if k == 1 {
        let inv = (m.transpose() * &m).try_inverse().unwrap();
        b[p - 1] / (s2 * inv[(p - 1, p - 1)]).sqrt()
    } else {
        f64::NAN
    };
    (t, f)
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

fn identity_only() -> PermutationSettings {
    PermutationSettings {
        permutations: 1,
        seed: 0,
    }
}

/// A random design: n subjects, interest continuous or g groups, up to two
/// covariates (one continuous, one categorical).
fn random_design(
    rng: &mut Rng,
    n: usize,
    g: usize,
    covariates: usize,
) -> (Regressor, Vec<Regressor>) {
    let interest = if g == 0 {
        continuous("age", (0..n).map(|_| normal(rng)).collect())
    } else {
        groups(&labels(n, g, rng))
    };
    let mut cov = Vec::new();
    if covariates >= 1 {
        cov.push(continuous(
            "weight",
            (0..n).map(|_| 3.0 + normal(rng)).collect(),
        ));
    }
    if covariates >= 2 {
        let l = labels(n, 2, rng);
        cov.push(Regressor {
            name: "site".into(),
            values: RegressorValues::Categorical(
                l.iter()
                    .map(|&i| ["north", "south"][i].to_string())
                    .collect(),
            ),
        });
    }
    (interest, cov)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(40))]

    #[test]
    fn statistics_match_a_direct_least_squares_fit(
        seed in any::<u64>(), n in 9usize..20, g in 0usize..4, covariates in 0usize..3,
    ) {
        let g = if g == 1 { 2 } else { g };
        let mut rng = Rng(seed);
        let (interest, cov) = random_design(&mut rng, n, g, covariates);
        let design = Design::new(interest.clone(), cov.clone()).unwrap();
        let columns = 3;
        let y: Vec<f64> = (0..n * columns).map(|_| 5.0 + normal(&mut rng)).collect();
        let result = permutation_test(&design, &y, &identity_only()).unwrap();
        prop_assert_eq!(result.permutations, 1);
        for j in 0..columns {
            let (t, f) = direct_statistic(&interest, &cov, &y[j * n..(j + 1) * n]);
            let s = result.statistic[j];
            match design.kind() {
                StatisticKind::T => {
                    prop_assert!(close(s, t, 1e-8), "t {} vs direct {}", s, t);
                    // t^2 = F for one tested column (two groups or continuous).
                    prop_assert!(close(s * s, f, 1e-8), "t^2 {} vs F {}", s * s, f);
                }
                StatisticKind::F => prop_assert!(close(s, f, 1e-8), "F {} vs direct {}", s, f),
            }
        }
        let k = columns_of(&interest).len();
        let p = 1 + cov.iter().map(|c| columns_of(c).len()).sum::<usize>() + k;
        prop_assert_eq!(design.degrees_of_freedom(), (k as f64, (n - p) as f64));
        prop_assert_eq!(design.model_matrix().len(), n * p);
    }

    #[test]
    fn shifting_and_scaling_y_changes_nothing(
        seed in any::<u64>(), g in 0usize..4, covariates in 0usize..2,
        shift in -100.0f64..100.0, scale in 0.01f64..100.0,
    ) {
        let g = if g == 1 { 2 } else { g };
        let mut rng = Rng(seed);
        let n = 14;
        let (interest, cov) = random_design(&mut rng, n, g, covariates);
        let design = Design::new(interest, cov).unwrap();
        let y: Vec<f64> = (0..n * 5).map(|_| normal(&mut rng)).collect();
        let moved: Vec<f64> = y.iter().map(|v| shift + scale * v).collect();
        let settings = PermutationSettings { permutations: 60, seed };
        let a = permutation_test(&design, &y, &settings).unwrap();
        let b = permutation_test(&design, &moved, &settings).unwrap();
        for j in 0..5 {
            prop_assert!(close(a.statistic[j], b.statistic[j], 1e-7));
        }
        prop_assert_eq!(&a.p_uncorrected, &b.p_uncorrected);
        prop_assert_eq!(&a.p_fwe, &b.p_fwe);
    }
}

#[test]
fn freedman_lane_without_covariates_is_plain_permutation_of_y() {
    let mut rng = Rng(11);
    let n = 12;
    for interest in [
        groups(&labels(n, 2, &mut rng)),
        groups(&labels(n, 3, &mut rng)),
        { continuous("age", (0..n).map(|_| normal(&mut rng)).collect()) },
    ] {
        let design = Design::new(interest, vec![]).unwrap();
        let columns = 4;
        let y: Vec<f64> = (0..n * columns).map(|_| 2.0 + normal(&mut rng)).collect();
        for trial in 0..5 {
            let mut src: Vec<u32> = (0..n as u32).collect();
            Shuffles::Random { count: 10, seed: 3 }.fill(trial + 1, &mut src);
            let identity: Vec<u32> = (0..n as u32).collect();
            let shuffles = Shuffles::Listed(vec![identity, src.clone()]);
            let result = permutation::run(&design, &y, &shuffles);
            // Subject j takes design row src[j]: the same as moving y_j to src[j].
            let mut permuted = vec![0.0; y.len()];
            for c in 0..columns {
                for j in 0..n {
                    permuted[c * n + src[j] as usize] = y[c * n + j];
                }
            }
            let plain = permutation_test(&design, &permuted, &identity_only()).unwrap();
            let max = plain.statistic.iter().fold(0.0f64, |m, s| m.max(s.abs()));
            assert!(
                close(result.max_null[1], max, 1e-10),
                "Freedman-Lane {} vs plain {}",
                result.max_null[1],
                max
            );
        }
    }
}

/// Every permutation of 0..n (Heap's algorithm), independent of the
/// library's enumeration.
fn all_permutations(n: usize) -> Vec<Vec<usize>> {
    fn heap(k: usize, a: &mut Vec<usize>, out: &mut Vec<Vec<usize>>) {
        if k <= 1 {
            out.push(a.clone());
            return;
        }
        for i in 0..k {
            heap(k - 1, a, out);
            if k.is_multiple_of(2) {
                a.swap(i, k - 1)
            } else {
                a.swap(0, k - 1)
            }
        }
    }
    let mut out = Vec::new();
    heap(n, &mut (0..n).collect(), &mut out);
    out
}

/// p-values from a table `stats[perm][column]` (the identity anywhere in
/// it, `observed` the identity's row).
fn brute_p(stats: &[Vec<f64>], observed: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let total = stats.len() as f64;
    let maxes: Vec<f64> = stats
        .iter()
        .map(|row| row.iter().fold(0.0f64, |m, s| m.max(s.abs())))
        .collect();
    let at_least = |a: f64, b: f64| a >= b.abs() * (1.0 - 1e-9);
    let unc = (0..observed.len())
        .map(|j| {
            stats
                .iter()
                .filter(|row| at_least(row[j].abs(), observed[j]))
                .count() as f64
                / total
        })
        .collect();
    let fwe = observed
        .iter()
        .map(|&o| maxes.iter().filter(|&&m| at_least(m, o)).count() as f64 / total)
        .collect();
    (unc, fwe)
}

#[test]
fn exhaustive_enumeration_matches_brute_force_with_a_covariate() {
    let mut rng = Rng(5);
    let n = 6;
    let interest = groups(&[0, 1, 0, 1, 1, 0]);
    let cov = vec![continuous(
        "weight",
        (0..n).map(|_| normal(&mut rng)).collect(),
    )];
    let design = Design::new(interest.clone(), cov.clone()).unwrap();
    let columns = 3;
    let y: Vec<f64> = (0..n * columns).map(|_| normal(&mut rng)).collect();
    let result = permutation_test(&design, &y, &PermutationSettings::default()).unwrap();
    assert!(result.exhaustive);
    assert_eq!(result.permutations, 720);

    // Freedman-Lane by hand: y* = P e + H_Z y, each fitted directly.
    let z = matrix(n, &[vec![1.0; n], columns_of(&cov[0]).remove(0)]);
    let mut stats = vec![vec![0.0; columns]; 720];
    let mut observed = vec![0.0; columns];
    for j in 0..columns {
        let yj = DVector::from_column_slice(&y[j * n..(j + 1) * n]);
        let (_, bz) = least_squares(&z, &yj);
        let fitted = &z * bz;
        let e = &yj - &fitted;
        observed[j] = direct_statistic(&interest, &cov, yj.as_slice()).0;
        for (k, pi) in all_permutations(n).iter().enumerate() {
            let ystar: Vec<f64> = (0..n).map(|i| e[pi[i]] + fitted[i]).collect();
            stats[k][j] = direct_statistic(&interest, &cov, &ystar).0;
        }
    }
    let (unc, fwe) = brute_p(&stats, &observed);
    for j in 0..columns {
        assert!(close(result.statistic[j], observed[j], 1e-8));
        assert!(
            (result.p_uncorrected[j] - unc[j]).abs() < 1e-12,
            "{} vs {}",
            result.p_uncorrected[j],
            unc[j]
        );
        assert!(
            (result.p_fwe[j] - fwe[j]).abs() < 1e-12,
            "{} vs {}",
            result.p_fwe[j],
            fwe[j]
        );
    }
}

#[test]
fn exhaustive_relabelings_match_brute_force_over_all_permutations() {
    // Three groups, no covariate: 7! / (2! 2! 3!) = 210 distinct relabelings
    // stand for all 5040 permutations.
    let mut rng = Rng(8);
    let labels = [2, 0, 1, 2, 0, 2, 1];
    let n = labels.len();
    let design = Design::new(groups(&labels), vec![]).unwrap();
    let columns = 3;
    let y: Vec<f64> = (0..n * columns).map(|_| normal(&mut rng)).collect();
    let result = permutation_test(&design, &y, &PermutationSettings::default()).unwrap();
    assert!(result.exhaustive);
    assert_eq!(result.permutations, 210);
    assert_eq!(result.kind, StatisticKind::F);

    // One-way ANOVA F from group means, over every permutation of y.
    let anova = |y: &[f64]| {
        let mean = y.iter().sum::<f64>() / n as f64;
        let (mut between, mut within) = (0.0, 0.0);
        for g in 0..3 {
            let members: Vec<f64> = (0..n).filter(|&i| labels[i] == g).map(|i| y[i]).collect();
            let m = members.iter().sum::<f64>() / members.len() as f64;
            between += members.len() as f64 * (m - mean).powi(2);
            within += members.iter().map(|v| (v - m).powi(2)).sum::<f64>();
        }
        (between / 2.0) / (within / (n - 3) as f64)
    };
    let perms = all_permutations(n);
    let mut stats = vec![vec![0.0; columns]; perms.len()];
    let mut observed = vec![0.0; columns];
    for j in 0..columns {
        let yj = &y[j * n..(j + 1) * n];
        observed[j] = anova(yj);
        for (k, pi) in perms.iter().enumerate() {
            let ystar: Vec<f64> = (0..n).map(|i| yj[pi[i]]).collect();
            stats[k][j] = anova(&ystar);
        }
    }
    let (unc, fwe) = brute_p(&stats, &observed);
    for j in 0..columns {
        assert!(close(result.statistic[j], observed[j], 1e-8));
        assert!(
            (result.p_uncorrected[j] - unc[j]).abs() < 1e-12,
            "{} vs {}",
            result.p_uncorrected[j],
            unc[j]
        );
        assert!(
            (result.p_fwe[j] - fwe[j]).abs() < 1e-12,
            "{} vs {}",
            result.p_fwe[j],
            fwe[j]
        );
    }
}

#[test]
fn permuting_the_subjects_changes_nothing() {
    let mut rng = Rng(21);
    let n = 6;
    for (interest, cov) in [
        (
            groups(&[0, 0, 1, 1, 1, 0]),
            vec![continuous(
                "weight",
                (0..n).map(|_| normal(&mut rng)).collect(),
            )],
        ),
        (groups(&[0, 1, 2, 0, 1, 2]), vec![]),
        (
            continuous("age", (0..n).map(|_| normal(&mut rng)).collect()),
            vec![],
        ),
    ] {
        let columns = 4;
        let y: Vec<f64> = (0..n * columns).map(|_| normal(&mut rng)).collect();
        let design = Design::new(interest.clone(), cov.clone()).unwrap();
        let a = permutation_test(&design, &y, &PermutationSettings::default()).unwrap();
        assert!(a.exhaustive);

        let order = [3, 5, 0, 4, 1, 2];
        let reorder = |r: &Regressor| Regressor {
            name: r.name.clone(),
            values: match &r.values {
                RegressorValues::Categorical(v) => {
                    RegressorValues::Categorical(order.iter().map(|&i| v[i].clone()).collect())
                }
                RegressorValues::Continuous(v) => {
                    RegressorValues::Continuous(order.iter().map(|&i| v[i]).collect())
                }
            },
        };
        let moved_design =
            Design::new(reorder(&interest), cov.iter().map(reorder).collect()).unwrap();
        let moved_y: Vec<f64> = (0..columns)
            .flat_map(|c| order.iter().map(move |&i| (c, i)))
            .map(|(c, i)| y[c * n + i])
            .collect();
        let b = permutation_test(&moved_design, &moved_y, &PermutationSettings::default()).unwrap();
        for j in 0..columns {
            assert!(close(a.statistic[j], b.statistic[j], 1e-9));
            assert!((a.p_uncorrected[j] - b.p_uncorrected[j]).abs() < 1e-12);
            assert!((a.p_fwe[j] - b.p_fwe[j]).abs() < 1e-12);
        }
    }
}

#[test]
fn a_planted_effect_is_found_there_and_not_elsewhere() {
    let mut rng = Rng(2024);
    let n = 20;
    let group = labels(n, 2, &mut rng);
    let design = Design::new(groups(&group), vec![]).unwrap();
    assert_eq!(design.describe(), "t: B - A (2 groups: A 10, B 10)");
    let columns = 200;
    let planted = 20;
    let mut y: Vec<f64> = (0..n * columns).map(|_| normal(&mut rng)).collect();
    for c in 0..planted {
        for i in 0..n {
            y[c * n + i] += 3.0 * group[i] as f64;
        }
    }
    let result = permutation_test(
        &design,
        &y,
        &PermutationSettings {
            permutations: 1000,
            seed: 1,
        },
    )
    .unwrap();
    assert!(!result.exhaustive);
    assert_eq!(result.max_null.len(), 1000);
    let found: Vec<usize> = (0..columns).filter(|&c| result.p_fwe[c] < 0.05).collect();
    assert_eq!(
        found,
        (0..planted).collect::<Vec<_>>(),
        "p_fwe {:?}",
        &result.p_fwe[..planted]
    );
    println!(
        "planted: largest FWE p where planted {:.4}, smallest elsewhere {:.4}",
        result.p_fwe[..planted]
            .iter()
            .fold(0.0f64, |m, &p| m.max(p)),
        result.p_fwe[planted..]
            .iter()
            .fold(1.0f64, |m, &p| m.min(p))
    );
    // B - A is positive where planted.
    assert!(result.statistic[..planted].iter().all(|&t| t > 0.0));
    assert!(
        result
            .p_fwe
            .iter()
            .zip(&result.p_uncorrected)
            .all(|(f, u)| f >= u)
    );
}

#[test]
fn a_null_cohort_gives_the_nominal_rate_of_false_positives() {
    let n = 16;
    let columns = 30;
    let mut hits = 0;
    for seed in 0..40u64 {
        let mut rng = Rng(1000 + seed);
        let group = labels(n, 2, &mut rng);
        let weight: Vec<f64> = (0..n).map(|_| normal(&mut rng)).collect();
        // A strong nuisance effect of the covariate, no group effect.
        let y: Vec<f64> = (0..n * columns)
            .map(|i| 2.0 * weight[i % n] + normal(&mut rng))
            .collect();
        let design = Design::new(groups(&group), vec![continuous("weight", weight)]).unwrap();
        let result = permutation_test(
            &design,
            &y,
            &PermutationSettings {
                permutations: 200,
                seed,
            },
        )
        .unwrap();
        if result.p_fwe.iter().any(|&p| p < 0.05) {
            hits += 1;
        }
    }
    println!("null cohorts with a FWE p < 0.05: {hits} of 40");
    assert!(hits <= 5, "{hits} of 40 null cohorts had a FWE p < 0.05");
}

#[test]
fn every_bad_input_has_its_error() {
    let ab = |v: &[&str]| Regressor {
        name: "group".into(),
        values: RegressorValues::Categorical(v.iter().map(|s| s.to_string()).collect()),
    };
    let good = ab(&["A", "B", "A", "B", "A", "B"]);
    let cases: Vec<(Result<Design, GlmError>, GlmError)> = vec![
        (
            Design::new(
                ab(&["A", "B", "A"]),
                vec![continuous("w", vec![1.0, 2.0, 4.0])],
            ),
            GlmError::TooFewSubjects {
                subjects: 3,
                columns: 3,
            },
        ),
        (
            Design::new(ab(&["A", "A", "A", "A"]), vec![]),
            GlmError::SingleLevel {
                name: "group".into(),
                level: "A".into(),
            },
        ),
        (
            Design::new(ab(&["A", "B", " ", "B"]), vec![]),
            GlmError::MissingLevel {
                name: "group".into(),
                row: 2,
            },
        ),
        (
            Design::new(good.clone(), vec![continuous("w", vec![1.0; 5])]),
            GlmError::RegressorLength {
                name: "w".into(),
                expected: 6,
                found: 5,
            },
        ),
        (
            Design::new(good.clone(), vec![continuous("w", vec![7.0; 6])]),
            GlmError::RankDeficient {
                regressor: "w".into(),
            },
        ),
        (
            Design::new(
                continuous("age", vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]),
                vec![continuous(
                    "months",
                    vec![12.0, 24.0, 36.0, 48.0, 60.0, 72.0],
                )],
            ),
            GlmError::RankDeficient {
                regressor: "age".into(),
            },
        ),
        (
            Design::new(
                good.clone(),
                vec![continuous("w", vec![1.0, 2.0, f64::NAN, 4.0, 5.0, 6.0])],
            ),
            GlmError::NonFiniteRegressor {
                name: "w".into(),
                row: 2,
            },
        ),
        (
            Design::new(continuous("age", vec![30.0; 6]), vec![]),
            GlmError::ConstantInterest { name: "age".into() },
        ),
        (
            Design::new(good.clone(), vec![ab(&["x", "x", "x", "x", "x", "x"])]),
            GlmError::SingleLevel {
                name: "group".into(),
                level: "x".into(),
            },
        ),
    ];
    for (got, expected) in cases {
        let err = got.unwrap_err();
        assert_eq!(err, expected);
        assert!(!err.to_string().contains('\n'), "{err}");
    }

    let design = Design::new(good, vec![]).unwrap();
    let settings = PermutationSettings::default();
    let mut y = vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
    assert_eq!(
        permutation_test(&design, &y[..11], &settings).unwrap_err(),
        GlmError::LengthNotMultiple {
            len: 11,
            subjects: 6
        }
    );
    assert_eq!(
        permutation_test(&design, &[], &settings).unwrap_err(),
        GlmError::NoColumns
    );
    assert_eq!(
        permutation_test(
            &design,
            &y,
            &PermutationSettings {
                permutations: 0,
                seed: 0
            }
        )
        .unwrap_err(),
        GlmError::ZeroPermutations
    );
    assert_eq!(
        permutation_test(
            &design,
            &y,
            &PermutationSettings {
                permutations: usize::MAX,
                seed: 0
            }
        )
        .unwrap_err(),
        GlmError::TooManyPermutations {
            asked: usize::MAX,
            max: permutation::MAX_PERMUTATIONS
        }
    );
    y[8] = f64::INFINITY;
    assert_eq!(
        permutation_test(&design, &y, &settings).unwrap_err(),
        GlmError::NonFiniteValue {
            column: 1,
            subject: 2
        }
    );
}

#[test]
fn results_are_deterministic_for_a_seed_whatever_the_threads() {
    let mut rng = Rng(77);
    let n = 18;
    let design = Design::new(
        groups(&labels(n, 2, &mut rng)),
        vec![continuous(
            "weight",
            (0..n).map(|_| normal(&mut rng)).collect(),
        )],
    )
    .unwrap();
    // More columns than one chunk, relabelings not a multiple of a batch.
    let columns = 600;
    let y: Vec<f64> = (0..n * columns).map(|_| normal(&mut rng)).collect();
    let settings = PermutationSettings {
        permutations: 101,
        seed: 9,
    };
    let a = permutation_test(&design, &y, &settings).unwrap();
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let b = one_thread
        .install(|| permutation_test(&design, &y, &settings))
        .unwrap();
    assert_eq!(a, b);
    assert_eq!(a.permutations, 101);
    let observed_max = a.statistic.iter().fold(0.0f64, |m, s| m.max(s.abs()));
    assert_eq!(a.max_null[0], observed_max);
    let c = permutation_test(
        &design,
        &y,
        &PermutationSettings {
            seed: 10,
            ..settings
        },
    )
    .unwrap();
    assert_eq!(a.statistic, c.statistic);
    assert_ne!(a.max_null, c.max_null);

    // Each column is tested on its own: a split run gives the same
    // statistics and uncorrected p, and maxima whose maximum is the whole's.
    let half = 300 * n;
    let left = permutation_test(&design, &y[..half], &settings).unwrap();
    let right = permutation_test(&design, &y[half..], &settings).unwrap();
    assert_eq!([left.statistic, right.statistic].concat(), a.statistic);
    assert_eq!(
        [left.p_uncorrected, right.p_uncorrected].concat(),
        a.p_uncorrected
    );
    let joined: Vec<f64> = left
        .max_null
        .iter()
        .zip(&right.max_null)
        .map(|(l, r)| l.max(*r))
        .collect();
    assert_eq!(joined, a.max_null);
}

#[test]
fn designs_describe_themselves() {
    let three = Design::new(
        groups(&[0, 1, 2, 0, 1, 2, 2]),
        vec![continuous(
            "age",
            vec![30.0, 31.0, 25.0, 40.0, 35.0, 28.0, 33.0],
        )],
    )
    .unwrap();
    assert_eq!(three.kind(), StatisticKind::F);
    assert_eq!(three.levels().unwrap(), ["A", "B", "C"]);
    assert_eq!(three.subjects(), 7);
    assert_eq!(three.degrees_of_freedom(), (2.0, 3.0));
    assert_eq!(
        three.describe(),
        "F: group (3 groups: A 2, B 2, C 3), covariates age"
    );
    let slope = Design::new(continuous("ga", vec![30.0, 31.0, 25.0, 40.0]), vec![]).unwrap();
    assert_eq!(slope.kind(), StatisticKind::T);
    assert_eq!(slope.levels(), None);
    assert_eq!(slope.describe(), "t: ga (continuous, 4 subjects)");
    assert_eq!(serde_json::to_string(&StatisticKind::F).unwrap(), "\"f\"");
}

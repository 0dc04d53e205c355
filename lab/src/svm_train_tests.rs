//! Tests of the SVM: a non-linear problem, serialisation round trips and corrupt models,
//! calibration, and bad inputs.

#![allow(clippy::unwrap_used, clippy::needless_range_loop)]

use super::*;
use proto::rng::SplitMix64;
use vision::stages::svm::MODEL_VERSION;

/// XOR-like data: label = sign(x) == sign(y), points away from the axes, plus 3 noise
/// dimensions.
fn xor(n: usize, seed: u64) -> (Vec<Vec<f32>>, Vec<bool>) {
    let mut rng = SplitMix64::new(seed);
    let mut f = Vec::new();
    let mut l = Vec::new();
    for _ in 0..n {
        let sx = if rng.next_f64() < 0.5 { -1.0 } else { 1.0 };
        let sy = if rng.next_f64() < 0.5 { -1.0 } else { 1.0 };
        let mut v = vec![
            (sx * (0.3 + rng.next_f64())) as f32,
            (sy * (0.3 + rng.next_f64())) as f32,
        ];
        v.extend((0..3).map(|_| (rng.next_f64() - 0.5) as f32 * 0.2));
        f.push(v);
        l.push(sx == sy);
    }
    (f, l)
}

/// Training accuracy of the least-squares linear classifier on the features (with bias).
fn best_linear_accuracy(f: &[Vec<f32>], l: &[bool]) -> f64 {
    // Normal equations by Gaussian elimination; small and well conditioned here.
    let d = f[0].len() + 1;
    let mut a = vec![vec![0.0f64; d + 1]; d];
    for (x, &y) in f.iter().zip(l) {
        let mut row: Vec<f64> = x.iter().map(|&v| f64::from(v)).collect();
        row.push(1.0);
        let t = if y { 1.0 } else { -1.0 };
        for i in 0..d {
            for j in 0..d {
                a[i][j] += row[i] * row[j];
            }
            a[i][d] += row[i] * t;
        }
    }
    for i in 0..d {
        let p = a[i][i];
        for j in 0..=d {
            a[i][j] /= p;
        }
        for k in 0..d {
            if k != i {
                let m = a[k][i];
                for j in 0..=d {
                    a[k][j] -= m * a[i][j];
                }
            }
        }
    }
    let w: Vec<f64> = (0..d).map(|i| a[i][d]).collect();
    let correct = f
        .iter()
        .zip(l)
        .filter(|(x, y)| {
            let s: f64 = x
                .iter()
                .zip(&w)
                .map(|(&v, w)| f64::from(v) * w)
                .sum::<f64>()
                + w[d - 1];
            (s > 0.0) == **y
        })
        .count();
    correct as f64 / l.len() as f64
}

fn params() -> SvmParams {
    SvmParams {
        c: 10.0,
        gamma: 0.5,
        ..SvmParams::default()
    }
}

#[test]
fn learns_xor_which_no_linear_classifier_can() {
    let (f, l) = xor(200, 1);
    assert!(best_linear_accuracy(&f, &l) < 0.7);
    let model = fit(&f, &l, &params(), 3, 7).unwrap();
    let (tf, tl) = xor(200, 2);
    let correct = tf
        .iter()
        .zip(&tl)
        .filter(|(x, y)| (model.decision(x).unwrap() > 0.0) == **y)
        .count();
    assert!(correct >= 194, "{correct} of 200");
    assert!(model.support_vector_count() < 200);
    assert!(model.platt().a < 0.0);
}

#[test]
fn a_tiny_cache_gives_the_same_model() {
    let (f, l) = xor(80, 3);
    let full = fit_uncalibrated(&f, &l, &params()).unwrap();
    let small = SvmParams {
        cache_bytes: 0,
        ..params()
    };
    let tiny = fit_uncalibrated(&f, &l, &small).unwrap();
    assert_eq!(full, tiny);
}

#[test]
fn serialisation_round_trips_with_identical_decisions() {
    let (f, l) = xor(100, 4);
    let model = fit(&f, &l, &params(), 3, 1).unwrap();
    let json = model.to_json().unwrap();
    let back = Model::from_json(&json).unwrap();
    assert_eq!(back, model);
    for x in &f {
        assert_eq!(back.decision(x).unwrap(), model.decision(x).unwrap());
        assert_eq!(back.probability(x).unwrap(), model.probability(x).unwrap());
    }
}

/// Replaces a JSON field of a serialised model.
fn with_field(json: &str, field: &str, value: serde_json::Value) -> String {
    let mut v: serde_json::Value = serde_json::from_str(json).unwrap();
    v[field] = value;
    v.to_string()
}

#[test]
fn corrupt_models_fail_to_load_with_a_clear_error() {
    let (f, l) = xor(60, 5);
    let json = fit_uncalibrated(&f, &l, &params())
        .unwrap()
        .to_json()
        .unwrap();
    let err = |s: &str| Model::from_json(s).unwrap_err();
    assert!(matches!(err(&json[..json.len() / 2]), SvmError::Parse(_)));
    assert_eq!(
        err(&with_field(&json, "version", 2.into())),
        SvmError::Version {
            found: 2,
            expected: MODEL_VERSION
        }
    );
    let e = err(&with_field(&json, "dim", 4.into()));
    assert!(matches!(e, SvmError::InvalidModel(_)), "{e}");
    assert!(e.to_string().contains("dimension 4"), "{e}");
    let nan = "AADAfwAAAAAAAAAA"; // f32 NaN, 0, 0
    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let mean = v["mean"].as_str().unwrap().to_owned();
    v["mean"] = format!("{nan}{}", &mean[16..]).into();
    let e = err(&v.to_string());
    assert!(e.to_string().contains("not finite"), "{e}");
    assert!(matches!(
        err(&with_field(&json, "coef", "@@@@".into())),
        SvmError::Parse(_)
    ));
    assert!(matches!(
        err(&with_field(&json, "gamma", (-1.0).into())),
        SvmError::InvalidModel(_)
    ));
    assert!(matches!(
        err(&with_field(&json, "support_vectors", 1.into())),
        SvmError::InvalidModel(_)
    ));
}

#[test]
fn platt_probabilities_are_monotone_in_the_decision_value() {
    let (f, l) = xor(150, 6);
    let model = fit(&f, &l, &params(), 3, 2).unwrap();
    let platt = model.platt();
    let mut last = 0.0;
    for k in -400..=400 {
        let p = platt.probability(f64::from(k) * 0.01);
        assert!((0.0..=1.0).contains(&p));
        assert!(p >= last, "not monotone at {k}");
        last = p;
    }
    assert!(platt.probability(2.0) > 0.9);
    assert!(platt.probability(-2.0) < 0.1);
    // Far out the probabilities saturate without overflowing.
    assert_eq!(platt.probability(1e300), 1.0);
    assert_eq!(platt.probability(-1e300), 0.0);
}

#[test]
fn bad_inputs_are_errors() {
    let (f, l) = xor(40, 8);
    let model = fit_uncalibrated(&f, &l, &params()).unwrap();
    assert_eq!(
        model.decision(&[0.0; 3]),
        Err(SvmError::Dimension {
            index: 0,
            expected: 5,
            actual: 3
        })
    );
    assert_eq!(
        model.decision(&[f32::NAN; 5]),
        Err(SvmError::NonFinite { index: 0 })
    );
    let all_true = vec![true; f.len()];
    assert!(matches!(
        fit_uncalibrated(&f, &all_true, &params()),
        Err(SvmError::OneClass { .. })
    ));
    assert!(matches!(
        fit_uncalibrated(&f, &l[1..], &params()),
        Err(SvmError::LabelCount { .. })
    ));
    let bad = SvmParams {
        gamma: 0.0,
        ..params()
    };
    assert!(matches!(
        fit_uncalibrated(&f, &l, &bad),
        Err(SvmError::BadParameter { name: "gamma", .. })
    ));
    let mut ragged = f.clone();
    ragged[3].pop();
    assert!(matches!(
        fit_uncalibrated(&ragged, &l, &params()),
        Err(SvmError::Dimension { index: 3, .. })
    ));
}

#[test]
fn the_solver_meets_the_optimality_conditions() {
    let (f, l) = xor(120, 9);
    let p = SvmParams {
        c: 2.0,
        gamma: 0.7,
        tolerance: 1e-4,
        ..SvmParams::default()
    };
    let dim = f[0].len();
    let x: Vec<f32> = f.iter().flatten().copied().collect();
    let y: Vec<f64> = l.iter().map(|&b| if b { 1.0 } else { -1.0 }).collect();
    let s = solve(&x, dim, &y, &p);
    let balance: f64 = s.alpha.iter().zip(&y).map(|(a, y)| a * y).sum();
    assert!(balance.abs() < 1e-9, "Σαy = {balance}");
    assert!(s.alpha.iter().all(|&a| (0.0..=p.c).contains(&a)));
    let kernel = |i: usize, j: usize| {
        let d2: f64 = (0..dim)
            .map(|k| f64::from(x[i * dim + k] - x[j * dim + k]).powi(2))
            .sum();
        (-p.gamma * d2).exp()
    };
    let mut bound = 0;
    for i in 0..y.len() {
        let decision: f64 = (0..y.len())
            .map(|j| s.alpha[j] * y[j] * kernel(i, j))
            .sum::<f64>()
            - s.rho;
        let margin = y[i] * decision;
        let tol = 2e-3;
        if s.alpha[i] == 0.0 {
            assert!(margin >= 1.0 - tol, "sample {i}: α = 0, margin {margin}");
        } else if s.alpha[i] == p.c {
            bound += 1;
            assert!(margin <= 1.0 + tol, "sample {i}: α = C, margin {margin}");
        } else {
            assert!(
                (margin - 1.0).abs() <= tol,
                "sample {i}: free, margin {margin}"
            );
        }
    }
    assert!(bound < y.len() / 4);
}

proptest::proptest! {
    #[test]
    fn platt_is_monotone_for_any_negative_slope(a in -50.0f64..-1e-3, b in -10.0f64..10.0,
                                                 f in -10.0f64..10.0, df in 0.0f64..5.0) {
        let platt = Platt { a, b };
        proptest::prop_assert!(platt.probability(f + df) >= platt.probability(f));
    }
}

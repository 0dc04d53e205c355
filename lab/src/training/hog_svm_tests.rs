//! Tests of training on synthetic patches: held-out quality, augmentation, the AUC, the
//! report, and too little data. `bench_filter_stages` (ignored) times the stages in release.

#![allow(clippy::unwrap_used)]

use super::*;
use proto::rng::SplitMix64;
use vision::patch_fixtures::patches;

/// A configuration small enough for debug-mode tests.
fn small() -> TrainConfig {
    TrainConfig {
        held_out_fraction: 0.25,
        c_grid: vec![1.0, 10.0],
        gamma_grid: vec![0.5 / 288.0, 2.0 / 288.0],
        rotations_deg: vec![-15.0, 15.0],
        ..TrainConfig::default()
    }
}

#[test]
fn trains_a_filter_that_separates_balls_from_look_alikes() {
    let (pos, neg) = patches(80, 240, 42);
    let mut lines = Vec::new();
    let (model, report) = train(&pos, &neg, &small(), &mut |s| lines.push(s.to_owned())).unwrap();
    let m = report.held_out;
    assert_eq!(m.true_positives + m.false_negatives, 20);
    assert_eq!(m.true_negatives + m.false_positives, 60);
    assert!(m.precision >= 0.95, "{report}");
    assert!(m.recall >= 0.95, "{report}");
    assert!(m.auc >= 0.98, "{report}");
    assert_eq!(report.grid.len(), 4);
    assert_eq!(report.train_samples, 60 * 6 + 180);
    assert!(lines.len() >= 6);
    let table = report.to_string();
    assert!(
        table.contains("precision") && table.contains(" *"),
        "{table}"
    );
    // The model survives serialisation and scores a fresh ball above a fresh edge.
    let back = Model::from_json(&model.to_json().unwrap()).unwrap();
    let (p, n) = patches(1, 1, 1234);
    assert_eq!(
        back.probability(&hog(&p[0])),
        model.probability(&hog(&p[0]))
    );
    assert!(back.probability(&hog(&p[0])).unwrap() > back.probability(&hog(&n[0])).unwrap());
}

#[test]
fn positives_are_augmented_tenfold_by_default() {
    let (pos, _) = patches(1, 0, 3);
    let cfg = TrainConfig::default();
    let aug = augment(&pos[0], cfg.mirror, &cfg.rotations_deg);
    assert_eq!(aug.len(), 10);
    assert_eq!(aug[0], pos[0]);
    assert_eq!(aug[1], pos[0].mirrored());
}

#[test]
fn auc_counts_ties_as_half() {
    assert_eq!(
        roc_auc(&[0.1, 0.2, 0.8, 0.9], &[false, false, true, true]),
        1.0
    );
    assert_eq!(
        roc_auc(&[0.9, 0.8, 0.2, 0.1], &[false, false, true, true]),
        0.0
    );
    assert_eq!(roc_auc(&[0.5, 0.5], &[false, true]), 0.5);
    assert_eq!(
        roc_auc(&[0.1, 0.6, 0.4, 0.9], &[false, false, true, true]),
        0.75
    );
    let m = Metrics::from_scores(&[0.1, 0.6, 0.4, 0.9], &[false, false, true, true], 0.5);
    assert_eq!(
        (
            m.true_positives,
            m.false_positives,
            m.true_negatives,
            m.false_negatives
        ),
        (1, 1, 1, 1)
    );
    assert_eq!((m.precision, m.recall), (0.5, 0.5));
}

#[test]
fn too_little_data_or_a_bad_configuration_is_an_error() {
    let (pos, neg) = patches(1, 5, 9);
    assert!(matches!(
        train(&pos, &neg, &small(), &mut |_| {}),
        Err(TrainError::TooFew { .. })
    ));
    let cfg = TrainConfig {
        folds: 1,
        ..small()
    };
    assert!(matches!(
        train(&neg, &neg, &cfg, &mut |_| {}),
        Err(TrainError::Config(_))
    ));
}

/// Times HOG, prediction and training on a seed-sized synthetic set (250 balls, 2000
/// non-balls), and checks what it timed: a model that separates the held-out patches, a
/// ball that passes the colour check, finite probabilities. Run with
/// `cargo test --release -p lab bench_filter_stages -- --ignored --nocapture`.
#[test]
#[ignore = "benchmark; run in release"]
fn bench_filter_stages() {
    use std::time::Instant;
    let (pos, neg) = patches(250, 2000, 77);
    let t = Instant::now();
    let mut sink = 0.0f32;
    let reps = 20;
    for _ in 0..reps {
        for p in pos.iter().chain(&neg) {
            sink += hog(p)[5];
        }
    }
    let hog_us = t.elapsed().as_secs_f64() * 1e6 / (reps * (pos.len() + neg.len())) as f64;
    let cfg = TrainConfig::default();
    let t = Instant::now();
    let (model, report) = train(&pos, &neg, &cfg, &mut |s| println!("  {s}")).unwrap();
    let train_s = t.elapsed().as_secs_f64();
    let features: Vec<_> = neg.iter().chain(&pos).map(hog).collect();
    let t = Instant::now();
    let mut acc = 0.0;
    for f in &features {
        acc += model.probability(f).unwrap();
    }
    let predict_us = t.elapsed().as_secs_f64() * 1e6 / features.len() as f64;
    let json_kb = model.to_json().unwrap().len() as f64 / 1024.0;
    let (image, centre, radius) = vision::patch_fixtures::ball_frame(&mut SplitMix64::new(5));
    let patch_cfg = vision::settings::PatchConfig::default();
    let colour_cfg = vision::settings::ColourCheckConfig::default();
    let thresholds = vision::settings::HsvThresholds {
        hue_lo_deg: 10.0,
        hue_hi_deg: 45.0,
        sat_min: 0.4,
        sat_max: 1.0,
        val_min: 0.2,
        val_max: 1.0,
    };
    let reps = 2000;
    let t = Instant::now();
    for _ in 0..reps {
        sink += vision::stages::patch::extract(&image, centre, radius, &patch_cfg)
            .unwrap()
            .grey()[0];
    }
    let extract_us = t.elapsed().as_secs_f64() * 1e6 / f64::from(reps);
    let t = Instant::now();
    let mut passes = 0;
    for _ in 0..reps {
        let c = vision::stages::colour::colour_check(
            &image,
            centre,
            radius,
            &thresholds,
            None,
            &colour_cfg,
        );
        passes += usize::from(c.unwrap().passes);
    }
    let colour_us = t.elapsed().as_secs_f64() * 1e6 / f64::from(reps);
    println!(
        "patch extraction {extract_us:.1} µs and colour check {colour_us:.1} µs at radius \
         {radius:.1} px ({passes} of {reps} pass)"
    );
    println!("{report}");
    println!(
        "HOG {hog_us:.2} µs/patch; prediction {predict_us:.1} µs with {} support vectors; \
         training {train_s:.1} s; model {json_kb:.0} KB ({sink:.1} {acc:.1})",
        model.support_vector_count()
    );
    assert!(report.held_out.auc > 0.95, "{report}");
    assert!(model.support_vector_count() > 0 && acc.is_finite() && sink.is_finite());
    assert!(passes > 1000, "{passes} of {reps} pass the colour check");
    assert!(hog_us > 0.0 && predict_us > 0.0 && extract_us > 0.0 && colour_us > 0.0);
}

#[test]
fn training_is_deterministic() {
    let (pos, neg) = patches(12, 30, 8);
    let cfg = TrainConfig {
        c_grid: vec![10.0],
        gamma_grid: vec![1.0 / 288.0],
        ..small()
    };
    let (a, ra) = train(&pos, &neg, &cfg, &mut |_| {}).unwrap();
    let (b, rb) = train(&pos, &neg, &cfg, &mut |_| {}).unwrap();
    assert_eq!(a.to_json().unwrap(), b.to_json().unwrap());
    assert_eq!(ra, rb);
}

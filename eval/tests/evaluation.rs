//! The evaluation's targets as tests, with looser floors than the targets themselves (those
//! are measured by `evaluate` over 20 seeds and reported in docs/accuracy.md): a regression
//! in the fusion core fails here.

use eval::report::Row;
use eval::scenarios::{evaluate, report};
use sim::Summary;

const SEEDS: u64 = 3;

fn rows(scenarios: &[&str]) -> Vec<Row> {
    let results =
        evaluate(scenarios, SEEDS, &sim::SimConfig::default(), 2).expect("simulation runs");
    report(scenarios, SEEDS, &results).scenarios
}

fn row<'a>(rows: &'a [Row], scenario: &str, method: &str) -> &'a Summary {
    rows.iter()
        .find(|r| r.scenario == scenario && r.method == method)
        .map(|r| &r.summary)
        .unwrap_or_else(|| panic!("no row for {scenario} / {method}"))
}

fn val(v: Option<f64>, what: &str) -> f64 {
    v.unwrap_or_else(|| panic!("{what} was not measured"))
}

#[test]
fn seed_scenarios_score_far_above_the_seed() {
    let rows = rows(&sim::SEED_SCENARIOS);
    for s in sim::SEED_SCENARIOS {
        let f = row(&rows, s, "fusion");
        let b = row(&rows, s, "seed-baseline");
        let score = val(f.position_score, "score");
        assert!(
            score >= 0.95,
            "{s}: fusion position score {score:.3} < 0.95"
        );
        assert!(
            score > val(b.position_score, "baseline score"),
            "{s}: not better than the seed"
        );
        let rel = val(f.horizon_rel_error["1.0"].median, "rel error at 1 s");
        assert!(rel <= 0.2, "{s}: relative error at 1 s {rel:.3} > 0.2");
        let rel_b = val(b.horizon_rel_error["1.0"].median, "baseline rel error");
        assert!(
            rel < 0.5 * rel_b,
            "{s}: 1 s prediction {rel:.3} not far better than the seed's {rel_b:.3}"
        );
    }
}

#[test]
fn team_rally_predicts_through_wall_bounces() {
    let rows = rows(&["team-rally", "corner"]);
    for s in ["team-rally", "corner"] {
        let f = row(&rows, s, "fusion");
        let h1 = val(f.horizon_median(1.0), "1 s error");
        assert!(h1 <= 0.08, "{s}: median error at 1 s {h1:.3} m > 0.08");
        let hb = val(
            f.bounce_horizon_error_m["1.0"].median,
            "1 s error across bounces",
        );
        assert!(
            hb <= 0.15,
            "{s}: median error at 1 s across bounces {hb:.3} m > 0.15"
        );
        let oracle = val(row(&rows, s, "oracle").horizon_median(1.0), "oracle 1 s");
        assert!(
            h1 <= 1.5 * oracle.max(0.005),
            "{s}: 1 s error {h1:.3} vs oracle {oracle:.3}"
        );
    }
}

#[test]
fn phantom_and_late_packets_do_not_derail_the_estimate() {
    let rows = rows(&["phantom", "late-packets", "kick-restart"]);
    let p = row(&rows, "phantom", "fusion");
    let pull = val(p.phantom_pull_max_m, "phantom pull");
    assert!(pull <= 0.1, "phantom pulled the estimate {pull:.3} m");
    for s in ["late-packets", "kick-restart"] {
        let f = row(&rows, s, "fusion");
        let rmse = val(f.position_rmse_m, "RMSE");
        let b = val(
            row(&rows, s, "seed-baseline").position_rmse_m,
            "baseline RMSE",
        );
        assert!(
            rmse < 0.7 * b,
            "{s}: fused RMSE {rmse:.3} vs the seed's {b:.3}"
        );
        let stop = val(f.stop_error_m.median, "stop error");
        assert!(stop <= 0.3, "{s}: stop-point median error {stop:.3} m");
    }
}

//! The evaluation report: per scenario and method, the pooled metrics as JSON and as a
//! markdown table, and the targets checked against them.

use crate::methods::HORIZONS_S;
use crate::metrics::{Samples, mean, quantile, rms};
use serde::Serialize;
use std::collections::BTreeMap;

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Spread {
    pub median: Option<f64>,
    pub p90: Option<f64>,
    pub n: usize,
}

impl Spread {
    fn of(v: &[f64]) -> Self {
        Spread {
            median: quantile(v, 0.5),
            p90: quantile(v, 0.9),
            n: v.len(),
        }
    }
}

/// One row of the report: a method on a scenario, pooled over seeds.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Row {
    pub scenario: String,
    pub method: String,
    pub seeds: usize,
    /// Share of evaluation ticks at which the method had an estimate.
    pub coverage: f64,
    pub position_score: Option<f64>,
    pub position_rmse_m: Option<f64>,
    pub position_median_m: Option<f64>,
    pub velocity_rmse_mps: Option<f64>,
    pub velocity_score: Option<f64>,
    pub direction_error_deg: Option<f64>,
    pub distance_rel_error: Option<f64>,
    pub horizon_error_m: BTreeMap<String, Spread>,
    pub horizon_rel_error: BTreeMap<String, Spread>,
    /// Prediction errors over windows that contain a true wall bounce.
    pub bounce_horizon_error_m: BTreeMap<String, Spread>,
    pub stop_error_m: Spread,
    pub bounce_time_error_s: Spread,
    pub bounce_miss_rate: Option<f64>,
    /// Largest displacement of the estimate towards the phantom ball (phantom scenario).
    pub phantom_pull_max_m: Option<f64>,
    pub phantom_pull_p99_m: Option<f64>,
}

/// "0.1", "0.25", "1.0": horizon keys as the report names them.
pub fn horizon_key(h: f64) -> String {
    if h.fract() == 0.0 {
        format!("{h:.1}")
    } else {
        format!("{h}")
    }
}

impl Row {
    pub fn new(scenario: &str, method: &str, seeds: usize, s: &Samples) -> Self {
        let per_h = |v: &Vec<Vec<f64>>| -> BTreeMap<String, Spread> {
            HORIZONS_S
                .iter()
                .zip(v)
                .map(|(h, x)| (horizon_key(*h), Spread::of(x)))
                .collect()
        };
        let bounce_scored = s.bounce_time_err_s.len() + s.bounce_missed;
        Row {
            scenario: scenario.to_string(),
            method: method.to_string(),
            seeds,
            coverage: if s.ticks_possible == 0 {
                0.0
            } else {
                s.ticks as f64 / s.ticks_possible as f64
            },
            position_score: mean(&s.scores),
            position_rmse_m: rms(&s.position_err_m),
            position_median_m: quantile(&s.position_err_m, 0.5),
            velocity_rmse_mps: rms(&s.velocity_err_mps),
            velocity_score: mean(&s.velocity_scores),
            direction_error_deg: mean(&s.direction_err_deg),
            distance_rel_error: mean(&s.distance_rel_err),
            horizon_error_m: per_h(&s.horizon_err_m),
            horizon_rel_error: per_h(&s.horizon_rel_err),
            bounce_horizon_error_m: per_h(&s.bounce_horizon_err_m),
            stop_error_m: Spread::of(&s.stop_err_m),
            bounce_time_error_s: Spread::of(&s.bounce_time_err_s),
            bounce_miss_rate: (bounce_scored > 0)
                .then(|| s.bounce_missed as f64 / bounce_scored as f64),
            phantom_pull_max_m: s.phantom_pull_m.iter().copied().reduce(f64::max),
            phantom_pull_p99_m: quantile(&s.phantom_pull_m, 0.99),
        }
    }

    pub fn horizon_median(&self, h: f64) -> Option<f64> {
        self.horizon_error_m
            .get(&horizon_key(h))
            .and_then(|s| s.median)
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct Report {
    pub seeds: usize,
    pub scenarios: Vec<Row>,
    pub targets: Vec<TargetCheck>,
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct TargetCheck {
    pub scenario: String,
    pub target: String,
    pub value: Option<f64>,
    pub limit: f64,
    pub met: bool,
}

fn cm(v: Option<f64>) -> String {
    v.map_or("–".into(), |x| format!("{:.1}", x * 100.0))
}

fn pct(v: Option<f64>) -> String {
    v.map_or("–".into(), |x| format!("{:.1}", x * 100.0))
}

/// The markdown table of all rows.
pub fn markdown_table(rows: &[Row]) -> String {
    let mut out = String::from(
        "| scenario | method | score % | RMSE cm | vel RMSE cm/s | err@0.5 s cm | err@1 s cm (p90) | rel@1 s % | err@1 s over bounce cm | stop cm | bounce time ms | phantom pull cm |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let h1 = r.horizon_error_m.get("1.0");
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} ({}) | {} | {} | {} | {} | {} |\n",
            r.scenario,
            r.method,
            pct(r.position_score),
            cm(r.position_rmse_m),
            cm(r.velocity_rmse_mps),
            cm(r.horizon_median(0.5)),
            cm(h1.and_then(|s| s.median)),
            cm(h1.and_then(|s| s.p90)),
            pct(r.horizon_rel_error.get("1.0").and_then(|s| s.median)),
            cm(r.bounce_horizon_error_m.get("1.0").and_then(|s| s.median)),
            cm(r.stop_error_m.median),
            r.bounce_time_error_s
                .median
                .map_or("–".into(), |x| format!("{:.0}", x * 1000.0)),
            cm(r.phantom_pull_max_m),
        ));
    }
    out
}

/// The targets, checked against the report rows.
pub fn check_targets(
    rows: &[Row],
    seed_scenarios: &[&str],
    team_scenarios: &[&str],
) -> Vec<TargetCheck> {
    let find = |s: &str, m: &str| rows.iter().find(|r| r.scenario == s && r.method == m);
    let mut out = Vec::new();
    let mut push =
        |scenario: &str, target: &str, value: Option<f64>, limit: f64, at_least: bool| {
            let met = value.is_some_and(|v| if at_least { v >= limit } else { v <= limit });
            out.push(TargetCheck {
                scenario: scenario.into(),
                target: target.into(),
                value,
                limit,
                met,
            });
        };
    for s in seed_scenarios {
        let Some(f) = find(s, "fusion") else { continue };
        push(s, "position score >= 0.97", f.position_score, 0.97, true);
        push(
            s,
            "median relative error at 1 s <= 0.10",
            f.horizon_rel_error.get("1.0").and_then(|x| x.median),
            0.10,
            false,
        );
    }
    for s in team_scenarios {
        let Some(f) = find(s, "fusion") else { continue };
        push(
            s,
            "median error at 1 s <= 0.05 m",
            f.horizon_median(1.0),
            0.05,
            false,
        );
        // Only where the ball bounced off a wall within a prediction window.
        if let Some(v) = f.bounce_horizon_error_m.get("1.0").and_then(|x| x.median) {
            push(
                s,
                "median error at 1 s across bounces <= 0.05 m",
                Some(v),
                0.05,
                false,
            );
        }
        push(
            s,
            "median stop-point error <= 0.05 m",
            f.stop_error_m.median,
            0.05,
            false,
        );
        if let (Some(single), Some(fr)) = (
            find(s, "best-single-robot").and_then(|r| r.position_rmse_m),
            f.position_rmse_m,
        ) {
            push(
                s,
                "RMSE / best single robot <= 0.6",
                Some(fr / single),
                0.6,
                false,
            );
        }
        if let Some(o) = find(s, "oracle") {
            let ratios = [
                (f.position_rmse_m, o.position_rmse_m),
                (f.horizon_median(1.0), o.horizon_median(1.0)),
                (f.stop_error_m.median, o.stop_error_m.median),
            ];
            let worst = ratios
                .iter()
                .filter_map(|(a, b)| Some(a.as_ref()? / b.as_ref()?.max(1e-3)))
                .reduce(f64::max);
            push(
                s,
                "error / oracle <= 1.2 (worst of RMSE, 1 s, stop)",
                worst,
                1.2,
                false,
            );
        }
        if let Some(pull) = f.phantom_pull_max_m {
            push(
                s,
                "pull towards the phantom <= 0.10 m",
                Some(pull),
                0.10,
                false,
            );
        }
    }
    out
}

pub const SECTION_BEGIN: &str = "<!-- evaluate:begin -->";
pub const SECTION_END: &str = "<!-- evaluate:end -->";

/// Replaces the text between the section markers of a markdown file (appending the section
/// when the markers are missing), leaving the hand-written discussion around it alone.
pub fn rewrite_section(path: &std::path::Path, section: &str) -> anyhow::Result<()> {
    let old = std::fs::read_to_string(path).unwrap_or_default();
    let block = format!("{SECTION_BEGIN}\n{section}{SECTION_END}");
    let new = match (old.find(SECTION_BEGIN), old.find(SECTION_END)) {
        (Some(a), Some(b)) if b > a => {
            format!("{}{block}{}", &old[..a], &old[b + SECTION_END.len()..])
        }
        _ => format!("{old}\n{block}\n"),
    };
    std::fs::write(path, new)?;
    Ok(())
}

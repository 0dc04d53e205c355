//! The evaluation report: per scenario and method, the pooled metrics as JSON and as a
//! markdown table, and the targets checked against them.

use serde::Serialize;
use sim::{Samples, Summary};

/// One row of the report: a method on a scenario, pooled over seeds.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Row {
    pub scenario: String,
    pub method: String,
    pub seeds: usize,
    #[serde(flatten)]
    pub summary: Summary,
}

impl Row {
    pub fn new(scenario: &str, method: &str, seeds: usize, s: &Samples) -> Self {
        Row {
            scenario: scenario.to_string(),
            method: method.to_string(),
            seeds,
            summary: Summary::of(s),
        }
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
        "| scenario | method | score % | RMSE cm | vel RMSE cm/s | err@0.5 s cm | err@1 s cm (p90) | rel@1 s % | err@1 s over bounce cm | stop cm | bounce time ms | phantom pull cm | first estimate ms (max) |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let m = &r.summary;
        let h1 = m.horizon_error_m.get("1.0");
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} ({}) | {} | {} | {} | {} | {} | {} |\n",
            r.scenario,
            r.method,
            pct(m.position_score),
            cm(m.position_rmse_m),
            cm(m.velocity_rmse_mps),
            cm(m.horizon_median(0.5)),
            cm(h1.and_then(|s| s.median)),
            cm(h1.and_then(|s| s.p90)),
            pct(m.horizon_rel_error.get("1.0").and_then(|s| s.median)),
            cm(m.bounce_horizon_error_m.get("1.0").and_then(|s| s.median)),
            cm(m.stop_error_m.median),
            m.bounce_time_error_s
                .median
                .map_or("–".into(), |x| format!("{:.0}", x * 1000.0)),
            cm(m.phantom_pull_max_m),
            match (m.acquisition_s.median, m.acquisition_max_s) {
                (Some(med), Some(max)) => format!("{:.0} ({:.0})", med * 1000.0, max * 1000.0),
                _ => "–".into(),
            },
        ));
    }
    out
}

/// The targets, checked against the report rows.
pub fn check_targets(
    rows: &[Row],
    seed_scenarios: &[&str],
    team_scenarios: &[&str],
    slow_robot_scenarios: &[&str],
) -> Vec<TargetCheck> {
    let find = |s: &str, m: &str| {
        rows.iter()
            .find(|r| r.scenario == s && r.method == m)
            .map(|r| &r.summary)
    };
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
    for s in slow_robot_scenarios {
        let Some(f) = find(s, "fusion") else { continue };
        // A run with no estimate at all fails the target; the slowest run is reported
        // beside it (a dropped frame or two right after the first sighting delays any rule).
        let median = (f.never_acquired == 0)
            .then_some(f.acquisition_s.median)
            .flatten();
        push(
            s,
            "median time to first estimate <= 0.5 s",
            median,
            0.5,
            false,
        );
        push(
            s,
            "slowest first estimate over the seeds <= 1.2 s",
            f.acquisition_max_s,
            1.2,
            false,
        );
        push(
            s,
            "median relative error at 1 s <= 0.10",
            f.horizon_rel_error.get("1.0").and_then(|x| x.median),
            0.10,
            false,
        );
    }
    out
}

/// Writes a report as pretty JSON, creating the folder.
pub fn write_json(path: &std::path::Path, report: &impl Serialize) -> anyhow::Result<()> {
    use anyhow::Context;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(path, serde_json::to_string_pretty(report)?)
        .with_context(|| format!("writing {}", path.display()))?;
    eprintln!("wrote {}", path.display());
    Ok(())
}

pub const SECTION_BEGIN: &str = "<!-- evaluate:begin -->";
pub const SECTION_END: &str = "<!-- evaluate:end -->";

/// Replaces the text between the section markers of a markdown file (appending the section
/// when the markers are missing), leaving the hand-written discussion around it alone.
pub fn rewrite_section(path: &std::path::Path, section: &str) -> anyhow::Result<()> {
    rewrite_section_between(path, SECTION_BEGIN, SECTION_END, section)
}

/// [`rewrite_section`] between other markers, so that one file can hold several sections.
pub fn rewrite_section_between(
    path: &std::path::Path,
    begin: &str,
    end: &str,
    section: &str,
) -> anyhow::Result<()> {
    let old = std::fs::read_to_string(path).unwrap_or_default();
    // The end marker on a line of its own, even after a table.
    let newline = if section.ends_with('\n') { "" } else { "\n" };
    let block = format!("{begin}\n{section}{newline}{end}");
    let new = match (old.find(begin), old.find(end)) {
        (Some(a), Some(b)) if b > a => format!("{}{block}{}", &old[..a], &old[b + end.len()..]),
        _ => format!("{old}\n{block}\n"),
    };
    std::fs::write(path, new)?;
    Ok(())
}

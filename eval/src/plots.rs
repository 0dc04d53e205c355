//! The evaluation's pictures: prediction error against horizon per method, and one
//! team-rally trajectory, true against predicted, with bounce markers.

use crate::methods::{Method, fusion_config};
use crate::plot::{Chart, Marker, PALETTE, RectOutline, Series, Style, write_png};
use crate::scenarios::{RunResult, is_team};
use fusion_server::Fusion;
use fusion_server::{Bounds, fly};
use sim::{BallEvent, SimRun};
use sim::{HORIZONS_S, Samples, quantile};
use std::path::Path;

fn method_color(m: Method) -> [u8; 3] {
    match m {
        Method::Fusion => PALETTE[0],
        Method::Oracle => PALETTE[2],
        Method::BestSingleRobot => PALETTE[1],
        Method::SeedBaseline => PALETTE[3],
    }
}

/// Median prediction error against horizon, pooled over the team or the seed scenarios.
pub fn horizon_chart(results: &[RunResult], team: bool) -> Chart {
    let group = if team {
        "team scenarios"
    } else {
        "seed scenarios"
    };
    let mut chart = Chart::new(
        format!("Prediction error against horizon ({group}, median)"),
        "horizon (s)",
        "position error (m)",
    );
    for m in [
        Method::Fusion,
        Method::Oracle,
        Method::BestSingleRobot,
        Method::SeedBaseline,
    ] {
        let mut pooled = Samples::new();
        for r in results.iter().filter(|r| is_team(&r.scenario) == team) {
            for (mm, s) in &r.methods {
                if *mm == m {
                    pooled.merge(s.clone());
                }
            }
        }
        let pts: Vec<(f64, f64)> = HORIZONS_S
            .iter()
            .zip(&pooled.horizon_err_m)
            .filter_map(|(h, v)| Some((*h, quantile(v, 0.5)?)))
            .collect();
        if !pts.is_empty() {
            chart.series.push(Series::new(
                m.name(),
                method_color(m),
                Style::LineAndMarkers(Marker::Circle),
                pts,
            ));
        }
    }
    chart.x_range = Some((0.0, 2.1));
    chart
}

/// The true path of a run, with the fused prediction made half a second before each of the
/// first bounces drawn through its predicted bounce.
pub fn trajectory_chart(run: &SimRun) -> Chart {
    let mut chart = Chart::new(
        format!(
            "{} seed {}: true path and fused predictions",
            run.scenario, run.seed
        ),
        "x (m)",
        "y (m)",
    );
    chart.equal_aspect = true;
    chart.width_px = 1000;
    chart.height_px = 720;
    let (hx, hy) = (run.pitch.half_length_m(), run.pitch.half_width_m());
    chart.rects.push(RectOutline {
        x0: -hx,
        y0: -hy,
        x1: hx,
        y1: hy,
        color: [60, 60, 60],
    });
    let truth: Vec<(f64, f64)> = run
        .truth
        .iter()
        .map(|s| (s.position_m[0], s.position_m[1]))
        .collect();
    chart.series.push(Series::new(
        "true path",
        [150, 150, 150],
        Style::Line,
        truth,
    ));
    let bounces: Vec<(f64, f64)> = run
        .events
        .iter()
        .filter_map(|e| match e {
            BallEvent::WallBounce { position_m, .. } => Some((position_m[0], position_m[1])),
            _ => None,
        })
        .collect();
    let bounce_times: Vec<f64> = run
        .events
        .iter()
        .filter_map(|e| match e {
            BallEvent::WallBounce { t_s, .. } => Some(*t_s),
            _ => None,
        })
        .collect();
    // Re-run the core and keep its state half a second before the first few bounces.
    let cfg = fusion_config(run);
    let bounds = Bounds::from_pitch(&cfg.pitch);
    let base = cfg.tracker.motion;
    let mut fusion = Fusion::new(cfg);
    let mut next = 0;
    let mut predicted_paths = Vec::new();
    let mut predicted_bounces = Vec::new();
    for t_b in bounce_times.iter().take(8) {
        let t_q = t_b - 0.5;
        let at = run.stamp_of(t_q);
        while let Some(d) = run.deliveries.get(next).filter(|d| d.arrival <= at) {
            fusion.ingest(&d.obs, d.arrival);
            next += 1;
        }
        let Some(f) = fusion.filter_at(at) else {
            continue;
        };
        let model = f.model(&base);
        let path: Vec<(f64, f64)> = (0..=30)
            .map(|k| fly(f.position(), f.velocity(), k as f64 * 0.05, &model, &bounds).position)
            .map(|p| (p[0], p[1]))
            .collect();
        let flight = fly(f.position(), f.velocity(), 1.5, &model, &bounds);
        predicted_bounces.extend(flight.hits().map(|h| (h.position[0], h.position[1])));
        predicted_paths.push(path);
    }
    for (k, path) in predicted_paths.into_iter().enumerate() {
        let label = if k == 0 {
            "fused prediction (1.5 s, from 0.5 s before a bounce)"
        } else {
            ""
        };
        chart
            .series
            .push(Series::new(label, PALETTE[0], Style::Dashed, path));
    }
    chart.series.push(Series::new(
        "true bounce",
        [200, 30, 30],
        Style::Markers(Marker::Cross),
        bounces,
    ));
    chart.series.push(Series::new(
        "predicted bounce",
        PALETTE[0],
        Style::Markers(Marker::Diamond),
        predicted_bounces,
    ));
    chart
}

/// Writes every plot into `dir`; returns the files written.
pub fn write_all(
    dir: &Path,
    results: &[RunResult],
    rally: Option<&SimRun>,
) -> anyhow::Result<Vec<String>> {
    std::fs::create_dir_all(dir)?;
    let mut written = Vec::new();
    for (team, file) in [
        (true, "horizon_error_team.png"),
        (false, "horizon_error_seed.png"),
    ] {
        if results.iter().any(|r| is_team(&r.scenario) == team) {
            let path = dir.join(file);
            write_png(&horizon_chart(results, team), &path)?;
            written.push(path.display().to_string());
        }
    }
    if let Some(run) = rally {
        let path = dir.join("team_rally_trajectory.png");
        write_png(&trajectory_chart(run), &path)?;
        written.push(path.display().to_string());
    }
    Ok(written)
}

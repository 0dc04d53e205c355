//! The vision evaluation's report: the fusion rows (scored by [`crate::scenarios`]'s code on the
//! agent's observations), detection precision and recall, confidence calibration, pipeline
//! time and the lens check, as JSON, markdown and one plot.

use crate::plot::{Chart, Marker, PALETTE, Series, Style, write_png};
use crate::report::{Report, TargetCheck};
use crate::scenarios;
use crate::vision::{FrameStat, LensError, SightingError, VisionResult};
use serde::Serialize;
use sim::{mean, quantile, rms};
use std::path::Path;

/// The name of a vision run's generated section in the docs (`<!-- NAME:begin -->` …
/// `<!-- NAME:end -->`): `evaluate-vision`, with `-patterned` for the patterned ball and
/// `-dissertation` (or the detector's name) for a detector other than the robot's default.
pub fn section_name(patterned: bool, detector: robot_agent::DetectorKind) -> String {
    let mut name = String::from("evaluate-vision");
    if patterned {
        name.push_str("-patterned");
    }
    if detector != robot_agent::DetectorKind::default() {
        name.push('-');
        name.push_str(detector.name());
    }
    name
}

/// Detection counted over frames, the way `sim_agent` counts against the truth.
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct Detection {
    pub frames: usize,
    /// Frames in which the ball is visible (see [`FrameStat`]).
    pub visible: usize,
    /// Visible balls the agent found.
    pub hits: usize,
    pub observations: usize,
    /// Observations that are not the ball.
    pub false_sightings: usize,
    pub recall: Option<f64>,
    pub precision: Option<f64>,
}

impl Detection {
    pub fn of<'a>(frames: impl IntoIterator<Item = &'a FrameStat>) -> Self {
        let mut d = Detection::default();
        for f in frames {
            d.frames += 1;
            d.visible += usize::from(f.visible);
            d.hits += usize::from(f.true_hit());
            d.observations += usize::from(f.observed);
            d.false_sightings += usize::from(f.false_sighting());
        }
        d.recall = (d.visible > 0).then(|| d.hits as f64 / d.visible as f64);
        let judged = d.hits + d.false_sightings;
        d.precision = (judged > 0).then(|| d.hits as f64 / judged as f64);
        d
    }
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ScenarioDetection {
    pub scenario: String,
    #[serde(flatten)]
    pub detection: Detection,
}

/// Observations whose confidence fell in [lo, hi): how sure the agent said it was against
/// how often it was right.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ConfidenceBin {
    pub lo: f64,
    pub hi: f64,
    pub observations: usize,
    pub mean_confidence: Option<f64>,
    pub ball_fraction: Option<f64>,
}

/// Recall among visible balls of an image radius in [lo, hi) pixels.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct RadiusBin {
    pub lo_px: f64,
    pub hi_px: f64,
    pub visible: usize,
    pub recall: Option<f64>,
}

/// The hits whose true floor range lies in [lo, hi) metres: their error in the image and
/// on the floor, against what the agent stated.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct RangeBin {
    pub lo_m: f64,
    pub hi_m: f64,
    pub hits: usize,
    /// Mean detected-minus-true centre, pixels (u, v), and mean radius error.
    pub mean_pixel_px: Option<[f64; 2]>,
    pub mean_radius_px: Option<f64>,
    /// RMS of the centre's distance from the truth and of the radius error, pixels.
    pub rms_pixel_px: Option<f64>,
    pub rms_radius_px: Option<f64>,
    /// Mean and RMS floor error along the view line (positive: too far), and RMS across.
    pub mean_along_m: Option<f64>,
    pub rms_along_m: Option<f64>,
    pub rms_across_m: Option<f64>,
    /// RMS of the stated standard deviations along and across.
    pub stated_along_m: Option<f64>,
    pub stated_across_m: Option<f64>,
    /// Mean NEES (2 when the covariance is honest) and the share inside the stated 95 %
    /// ellipse (NEES ≤ 5.99).
    pub mean_nees: Option<f64>,
    pub inside_95: Option<f64>,
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Timing {
    pub frames: usize,
    pub median_ms: Option<f64>,
    pub p99_ms: Option<f64>,
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct CalibrationCheck {
    /// The shipped calibration's RMS reprojection error on its chessboard views.
    pub shipped_rms_px: f64,
    /// Spacing of the pixel grid over the whole image.
    pub grid_step_px: f64,
    /// The fitted model against the simulator's true lens over that grid.
    pub lens: LensError,
}

#[derive(Debug, Clone, Serialize)]
pub struct VisionReport {
    pub seeds: usize,
    pub latency_s: f64,
    /// The fusion evaluation on the agent's observations (rows and the fusion targets).
    pub fusion: Report,
    pub detection: Vec<ScenarioDetection>,
    pub detection_overall: Detection,
    /// Published observations: confidence against how often they were the ball.
    pub confidence: Vec<ConfidenceBin>,
    /// Every candidate the classifier scored, published or not (the bins' `observations`
    /// count candidates), and the Brier score of those probabilities.
    pub candidate_calibration: Vec<ConfidenceBin>,
    pub candidate_brier: Option<f64>,
    pub recall_by_radius: Vec<RadiusBin>,
    pub accuracy_by_range: Vec<RangeBin>,
    pub timing: Timing,
    pub calibration: CalibrationCheck,
    pub targets: Vec<TargetCheck>,
}

const CONFIDENCE_EDGES: [f64; 6] = [0.0, 0.5, 0.8, 0.9, 0.95, 1.0001];
const CANDIDATE_EDGES: [f64; 7] = [0.0, 0.01, 0.1, 0.5, 0.9, 0.99, 1.0001];
const RADIUS_EDGES_PX: [f64; 8] = [4.0, 6.0, 8.0, 10.0, 14.0, 20.0, 30.0, 80.0];
const RANGE_EDGES_M: [f64; 7] = [0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 10.0];
/// χ² with two degrees of freedom at 95 %.
const CHI2_2DOF_95: f64 = 5.991;

fn range_bins(frames: &[&FrameStat]) -> Vec<RangeBin> {
    RANGE_EDGES_M
        .windows(2)
        .map(|w| {
            let e: Vec<SightingError> = frames
                .iter()
                .filter_map(|f| f.error)
                .filter(|e| (w[0]..w[1]).contains(&e.range_m))
                .collect();
            // One field of every sighting error, for the slice statistics.
            let of = |f: fn(&SightingError) -> f64| e.iter().map(f).collect::<Vec<f64>>();
            RangeBin {
                lo_m: w[0],
                hi_m: w[1],
                hits: e.len(),
                mean_pixel_px: mean(&of(|e| e.pixel_px[0]))
                    .zip(mean(&of(|e| e.pixel_px[1])))
                    .map(|(u, v)| [u, v]),
                mean_radius_px: mean(&of(|e| e.radius_px)),
                rms_pixel_px: rms(&of(|e| e.pixel_px[0].hypot(e.pixel_px[1]))),
                rms_radius_px: rms(&of(|e| e.radius_px)),
                mean_along_m: mean(&of(|e| e.along_m)),
                rms_along_m: rms(&of(|e| e.along_m)),
                rms_across_m: rms(&of(|e| e.across_m)),
                stated_along_m: rms(&of(|e| e.sigma_along_m)),
                stated_across_m: rms(&of(|e| e.sigma_across_m)),
                mean_nees: mean(&of(|e| e.nees)),
                inside_95: mean(&of(|e| f64::from(u8::from(e.nees <= CHI2_2DOF_95)))),
            }
        })
        .collect()
}

/// Probability against how often it was right, over (probability, was the ball) pairs.
fn calibration_bins(pairs: &[(f64, bool)], edges: &[f64]) -> Vec<ConfidenceBin> {
    edges
        .windows(2)
        .map(|w| {
            let inside: Vec<&(f64, bool)> = pairs
                .iter()
                .filter(|(c, _)| (w[0]..w[1]).contains(c))
                .collect();
            let n = inside.len();
            ConfidenceBin {
                lo: w[0],
                hi: w[1].min(1.0),
                observations: n,
                mean_confidence: (n > 0)
                    .then(|| inside.iter().map(|x| x.0).sum::<f64>() / n as f64),
                ball_fraction: (n > 0)
                    .then(|| inside.iter().filter(|x| x.1).count() as f64 / n as f64),
            }
        })
        .collect()
}

fn radius_bins(frames: &[&FrameStat]) -> Vec<RadiusBin> {
    RADIUS_EDGES_PX
        .windows(2)
        .map(|w| {
            let seen: Vec<&&FrameStat> = frames
                .iter()
                .filter(|f| f.visible && (w[0]..w[1]).contains(&f.radius_px))
                .collect();
            let hits = seen.iter().filter(|f| f.hit).count();
            RadiusBin {
                lo_px: w[0],
                hi_px: w[1],
                visible: seen.len(),
                recall: (!seen.is_empty()).then(|| hits as f64 / seen.len() as f64),
            }
        })
        .collect()
}

fn push_target(
    out: &mut Vec<TargetCheck>,
    scenario: &str,
    target: &str,
    value: Option<f64>,
    limit: f64,
    at_least: bool,
) {
    let met = value.is_some_and(|v| if at_least { v >= limit } else { v < limit });
    out.push(TargetCheck {
        scenario: scenario.into(),
        target: target.into(),
        value,
        limit,
        met,
    });
}

/// Condenses the results into the report and checks the vision targets.
pub fn report(
    scenarios: &[&str],
    seeds: u64,
    latency_s: f64,
    results: &[VisionResult],
    calibration: CalibrationCheck,
) -> VisionReport {
    let runs: Vec<scenarios::RunResult> = results.iter().map(|r| r.result.clone()).collect();
    let fusion = scenarios::report(scenarios, seeds, &runs);
    let all: Vec<&FrameStat> = results.iter().flat_map(|r| &r.frames).collect();
    let detection: Vec<ScenarioDetection> = scenarios
        .iter()
        .map(|s| ScenarioDetection {
            scenario: s.to_string(),
            detection: Detection::of(
                results
                    .iter()
                    .filter(|r| r.result.scenario == *s)
                    .flat_map(|r| &r.frames),
            ),
        })
        .collect();
    let ms: Vec<f64> = all.iter().map(|f| f.pipeline_ms).collect();
    let candidates: Vec<(f64, bool)> = all
        .iter()
        .flat_map(|f| f.candidates.iter().copied())
        .collect();
    let mut targets = Vec::new();
    for s in scenarios {
        let row = fusion
            .scenarios
            .iter()
            .find(|r| r.scenario == *s && r.method == "fusion");
        let det = detection
            .iter()
            .find(|d| d.scenario == *s)
            .map(|d| &d.detection);
        push_target(
            &mut targets,
            s,
            "position score >= 0.97",
            row.and_then(|r| r.summary.position_score),
            0.97,
            true,
        );
        push_target(
            &mut targets,
            s,
            "direction error < 1°",
            row.and_then(|r| r.summary.direction_error_deg),
            1.0,
            false,
        );
        push_target(
            &mut targets,
            s,
            "recall >= 0.97",
            det.and_then(|d| d.recall),
            0.97,
            true,
        );
        push_target(
            &mut targets,
            s,
            "precision >= 0.99",
            det.and_then(|d| d.precision),
            0.99,
            true,
        );
    }
    push_target(
        &mut targets,
        "all",
        "lens error (max) < 0.5 px",
        Some(calibration.lens.max_px),
        0.5,
        false,
    );
    VisionReport {
        seeds: seeds as usize,
        latency_s,
        fusion,
        detection,
        detection_overall: Detection::of(all.iter().copied()),
        confidence: calibration_bins(
            &all.iter()
                .filter_map(|f| Some((f.confidence?, f.hit)))
                .collect::<Vec<_>>(),
            &CONFIDENCE_EDGES,
        ),
        candidate_calibration: calibration_bins(&candidates, &CANDIDATE_EDGES),
        candidate_brier: mean(
            &candidates
                .iter()
                .map(|(p, ball)| (p - f64::from(u8::from(*ball))).powi(2))
                .collect::<Vec<f64>>(),
        ),
        recall_by_radius: radius_bins(&all),
        accuracy_by_range: range_bins(&all),
        timing: Timing {
            frames: ms.len(),
            median_ms: quantile(&ms, 0.5),
            p99_ms: quantile(&ms, 0.99),
        },
        calibration,
        targets,
    }
}

fn pct(v: Option<f64>) -> String {
    v.map_or("–".into(), |x| format!("{:.1}", x * 100.0))
}

fn num(v: Option<f64>, digits: usize) -> String {
    v.map_or("–".into(), |x| format!("{x:.digits$}"))
}

/// The seed's metrics per scenario and method, on the agent's observations.
pub fn metrics_table(rep: &VisionReport) -> String {
    let mut out = String::from(
        "| scenario | method | coverage % | score % | direction err ° | distance err % | vel RMSE cm/s | vel score % | err@1 s cm | rel@1 s % |\n|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in &rep.fusion.scenarios {
        let m = &r.summary;
        out.push_str(&format!(
            "| {} | {} | {:.1} | {} | {} | {} | {} | {} | {} | {} |\n",
            r.scenario,
            r.method,
            m.coverage * 100.0,
            pct(m.position_score),
            num(m.direction_error_deg, 2),
            pct(m.distance_rel_error),
            pct(m.velocity_rmse_mps),
            pct(m.velocity_score),
            pct(m.horizon_median(1.0)),
            pct(m.horizon_rel_error.get("1.0").and_then(|s| s.median)),
        ));
    }
    out
}

/// Detection per scenario and overall.
pub fn detection_table(rep: &VisionReport) -> String {
    let mut out = String::from(
        "| scenario | frames | ball visible | found | recall % | observations | false | precision % |\n|---|---|---|---|---|---|---|---|\n",
    );
    let rows = rep
        .detection
        .iter()
        .map(|d| (d.scenario.as_str(), &d.detection))
        .chain([("**all**", &rep.detection_overall)]);
    for (s, d) in rows {
        out.push_str(&format!(
            "| {s} | {} | {} | {} | {} | {} | {} | {} |\n",
            d.frames,
            d.visible,
            d.hits,
            pct(d.recall),
            d.observations,
            d.false_sightings,
            pct(d.precision)
        ));
    }
    out
}

/// A calibration table: probability bins against how often they were the ball.
fn calibration_table(what: &str, probability: &str, bins: &[ConfidenceBin]) -> String {
    let mut out = format!(
        "| {probability} | {what} | mean {probability} | was the ball % |\n|---|---|---|---|\n"
    );
    for b in bins {
        out.push_str(&format!(
            "| {:.2}–{:.2} | {} | {} | {} |\n",
            b.lo,
            b.hi,
            b.observations,
            num(b.mean_confidence, 3),
            pct(b.ball_fraction)
        ));
    }
    out
}

/// Confidence calibration, pipeline time and the lens check.
pub fn extras_table(rep: &VisionReport) -> String {
    let mut out = calibration_table("observations", "confidence", &rep.confidence);
    out.push_str(&format!(
        "\nEvery candidate the classifier scored (published or not; Brier score {}):\n\n{}",
        num(rep.candidate_brier, 4),
        calibration_table("candidates", "probability", &rep.candidate_calibration)
    ));
    let t = &rep.timing;
    let c = &rep.calibration;
    out.push_str(&format!(
        "\nPipeline time per frame (`Agent::on_frame`, {} frames): median {} ms, p99 {} ms.\n\n\
         Calibration: the shipped calibration's RMS reprojection error on its boards is {:.3} px; \
         against the simulator's true lens over a {:.0} px grid of the whole 640×360 image \
         ({} points, {} not projectable) the fitted model is off by {:.3} px RMS, {:.3} px at most.\n",
        t.frames,
        num(t.median_ms, 2),
        num(t.p99_ms, 2),
        c.shipped_rms_px,
        c.grid_step_px,
        c.lens.pixels,
        c.lens.failed,
        c.lens.rms_px,
        c.lens.max_px,
    ));
    out
}

/// Sighting error and stated uncertainty by range.
pub fn accuracy_table(rep: &VisionReport) -> String {
    let mut out = String::from(
        "| range m | hits | pixel bias u, v px | pixel RMS px | radius bias px | radius RMS px | along bias cm | along RMS cm | stated along cm | across RMS cm | stated across cm | mean NEES | inside 95 % |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let cm = |v: Option<f64>| num(v.map(|x| x * 100.0), 1);
    for b in rep.accuracy_by_range.iter().filter(|b| b.hits > 0) {
        out.push_str(&format!(
            "| {:.1}–{:.1} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            b.lo_m,
            b.hi_m,
            b.hits,
            b.mean_pixel_px
                .map_or("–".into(), |p| format!("{:+.2}, {:+.2}", p[0], p[1])),
            num(b.rms_pixel_px, 2),
            num(b.mean_radius_px, 2),
            num(b.rms_radius_px, 2),
            cm(b.mean_along_m),
            cm(b.rms_along_m),
            cm(b.stated_along_m),
            cm(b.rms_across_m),
            cm(b.stated_across_m),
            num(b.mean_nees, 2),
            pct(b.inside_95),
        ));
    }
    out
}

/// The targets as a markdown table.
pub fn targets_table(targets: &[TargetCheck]) -> String {
    let met = targets.iter().filter(|t| t.met).count();
    let mut s = format!(
        "Targets met: {met} of {}.\n\n| scenario | target | measured | met |\n|---|---|---|---|\n",
        targets.len()
    );
    for t in targets {
        s.push_str(&format!(
            "| {} | {} | {} | {} |\n",
            t.scenario,
            t.target,
            num(t.value, 3),
            if t.met { "yes" } else { "**no**" }
        ));
    }
    s
}

/// Everything printed and written into the document, after the line naming the command.
pub fn markdown(rep: &VisionReport) -> String {
    format!(
        "{}\n{}\n{}\n{}\n{}",
        metrics_table(rep),
        detection_table(rep),
        accuracy_table(rep),
        extras_table(rep),
        targets_table(&rep.targets)
    )
}

/// Detection recall against the ball's image radius.
pub fn recall_chart(rep: &VisionReport) -> Chart {
    let mut chart = Chart::new(
        "Detection recall by ball image radius (seed scenarios, rendered)",
        "ball image radius (px)",
        "recall",
    );
    let pts: Vec<(f64, f64)> = rep
        .recall_by_radius
        .iter()
        .filter_map(|b| Some((0.5 * (b.lo_px + b.hi_px.min(40.0)), b.recall?)))
        .collect();
    chart.series.push(Series::new(
        "recall",
        PALETTE[0],
        Style::LineAndMarkers(Marker::Circle),
        pts,
    ));
    chart
}

/// Writes the plot into `dir` as `name`; returns the file written.
pub fn write_plot(dir: &Path, name: &str, rep: &VisionReport) -> anyhow::Result<String> {
    std::fs::create_dir_all(dir)?;
    let path = dir.join(name);
    write_png(&recall_chart(rep), &path)?;
    Ok(path.display().to_string())
}

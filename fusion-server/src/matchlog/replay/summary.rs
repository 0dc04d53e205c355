//! What replay prints: the summary as text lines or as one JSON object, with every count
//! the engine and the fusion core kept.

use super::ReplayReport;
use proto::WallSide;

/// Files a replay wrote.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReplayOutputs {
    /// The re-fused match log's files.
    pub log_files: Vec<String>,
    /// The states as CSV.
    pub states_csv: Option<String>,
}

/// The summary as JSON (`wall_s`: how long the replay took).
pub fn summary_json(r: &ReplayReport, wall_s: f64, out: &ReplayOutputs) -> serde_json::Value {
    let rejected: serde_json::Map<String, serde_json::Value> = r
        .rejected
        .iter()
        .map(|((kind, reason), n)| (format!("{kind}/{reason}"), (*n).into()))
        .collect();
    serde_json::json!({
        "messages": r.messages,
        "statuses": r.statuses,
        "rejected": rejected,
        "observations": r.observations,
        "observations_accepted": r.observations_accepted,
        "observations_reordered": r.fusion.reordered,
        "observations_replayed": r.fusion.replayed,
        "observations_outside_walls": r.fusion.outside_walls,
        "observations_held": r.fusion.held_in_hypotheses,
        "kicks_inferred": r.fusion.kicks_inferred,
        "bounces_seen": r.fusion.bounces_seen,
        "states_recorded": r.states_recorded,
        "states_identical": r.states_identical,
        "states_written": r.states_written,
        "states_without_estimate": r.states_without_estimate,
        "scene_written": r.scene_written,
        "scene_replaced": r.scene_replaced,
        "other": r.other,
        "model": r.model.map(|m| serde_json::json!({
            "rolling_decel_mps2": m.rolling_decel_mps2,
            "wall_restitution": m.wall_restitution,
            "decel_samples": m.decel_samples,
            "restitution_samples": m.restitution_samples,
            "tangential_retention": m.tangential_retention,
            "slide_decel_mps2": m.slide_decel_mps2,
        })),
        "walls": walls_json(r),
        "span_s": r.span_s,
        "wall_s": wall_s,
        "log_files": out.log_files,
        "states_csv": out.states_csv,
    })
}

/// The summary as text lines (`wall_s`: how long the replay took).
pub fn summary_text(r: &ReplayReport, wall_s: f64) -> String {
    let mut lines = Vec::new();
    let mut line = |text: String| lines.push(text);
    line(format!("messages            {}", r.messages));
    line(format!(
        "observations        {} ({} accepted)",
        r.observations, r.observations_accepted
    ));
    for ((kind, reason), n) in &r.rejected {
        line(format!("  rejected {kind:<11} {reason:<20} {n}"));
    }
    if r.fusion.reordered > 0 {
        line(format!(
            "  out of order      {} slotted in by capture time, {} later ones re-applied",
            r.fusion.reordered, r.fusion.replayed
        ));
    }
    if r.fusion.outside_walls > 0 {
        line(format!(
            "  beyond a wall     {} accepted, ignored by the tracker",
            r.fusion.outside_walls
        ));
    }
    if r.fusion.held_in_hypotheses > 0 {
        line(format!(
            "  held              {} went to hypotheses that were not the estimate (awaiting promotion, or phantoms)",
            r.fusion.held_in_hypotheses
        ));
    }
    if r.fusion.bounces_seen > 0 || r.fusion.kicks_inferred > 0 {
        line(format!(
            "wall bounces        {} (the estimate went through)",
            r.fusion.bounces_seen
        ));
        line(format!(
            "kicks inferred      {} (runs of surprising sightings away from the walls)",
            r.fusion.kicks_inferred
        ));
    }
    line(format!("statuses            {}", r.statuses));
    line(format!("states recorded     {}", r.states_recorded));
    if r.states_recorded > 0 {
        line(format!(
            "states identical    {} of {}",
            r.states_identical, r.states_recorded
        ));
    }
    if let Some((at, was, now)) = &r.first_difference {
        line(format!(
            "first difference at {}:\n  recorded {was}\n  replayed {now}",
            at.0
        ));
    }
    line(format!("states written      {}", r.states_written));
    if r.states_without_estimate > 0 {
        line(format!(
            "  without estimate  {} (asked for before the ball was first seen)",
            r.states_without_estimate
        ));
    }
    if r.scene_written > 0 || r.scene_replaced > 0 {
        line(format!(
            "scene messages      {} written, {} of the log's replaced",
            r.scene_written, r.scene_replaced
        ));
    }
    if r.wall_bounces.iter().any(|n| *n > 0) {
        let walls: Vec<String> = WallSide::ALL
            .iter()
            .enumerate()
            .map(|(i, side)| {
                format!(
                    "{} {:+.3} m ({})",
                    side_name(*side),
                    r.wall_offsets_m[i],
                    r.wall_bounces[i]
                )
            })
            .collect();
        line(format!(
            "walls at the end    {} (outside + / inside −, bounces)",
            walls.join(", ")
        ));
    }
    if let Some(m) = &r.model {
        line(format!(
            "model at the end    deceleration {:.3} m/s² ({} samples), restitution {:.2} and \
             tangential retention {:.2} ({} bounces), slide {:.2} m/s²",
            m.rolling_decel_mps2,
            m.decel_samples,
            m.wall_restitution,
            m.tangential_retention,
            m.restitution_samples,
            m.slide_decel_mps2
        ));
    }
    line(format!(
        "match time          {:.1} s, replayed in {wall_s:.2} s ({:.0}x real time)",
        r.span_s,
        r.span_s / wall_s.max(1e-9)
    ));
    lines.push(String::new());
    lines.join("\n")
}

fn side_name(side: WallSide) -> &'static str {
    match side {
        WallSide::XMax => "x_max",
        WallSide::XMin => "x_min",
        WallSide::YMax => "y_max",
        WallSide::YMin => "y_min",
    }
}

/// Per wall: how far outside (+) or inside (−) the pitch's bounds the ball turns, and the
/// bounces that measured it.
fn walls_json(r: &ReplayReport) -> serde_json::Value {
    WallSide::ALL
        .iter()
        .enumerate()
        .map(|(i, side)| {
            (
                side_name(*side).to_string(),
                serde_json::json!({
                    "offset_m": r.wall_offsets_m[i],
                    "bounces": r.wall_bounces[i],
                }),
            )
        })
        .collect::<serde_json::Map<_, _>>()
        .into()
}

//! Simulated matches as match logs: written with the simulator's ground truth beside the
//! observations, and scored back from a log the way the evaluation scores a run. The
//! server's replay knows nothing of the truth channels; it copies them through.

use crate::scoring::run_fusion;
use fusion_server::FusionConfig;
use fusion_server::LogMessage;
use fusion_server::ReplaySink;
use fusion_server::Schema;
use proto::{KeySpace, Stamp};
use sim::{Delivery, ObsKind, SimRun};
use sim::{Spread, Summary, score, tick_count};
use sim::{TruthLogBuilder, TruthLogError};
use std::sync::Arc;

/// The JSON Schemas of the ground-truth channels, for a match-log writer.
pub fn truth_schemas() -> Vec<Arc<Schema>> {
    sim::truth_schemas()
        .into_iter()
        .map(|(name, schema)| {
            let json = serde_json::to_vec_pretty(&schema).unwrap_or_default();
            Arc::new(Schema::new(name, json))
        })
        .collect()
}

/// Writes a simulated match as a match log: every observation on its robot's key at the
/// time it reaches the server, and the simulator's ground truth. Returns the messages
/// written.
pub fn write_simulated(
    run: &SimRun,
    keys: &KeySpace,
    sink: &mut dyn ReplaySink,
) -> Result<usize, proto::KeyError> {
    let truth = sim::truth_messages(run);
    let mut out: Vec<(Stamp, String, &str, Vec<u8>)> = Vec::with_capacity(truth.len());
    for m in truth {
        out.push((m.log_time, m.topic.to_string(), m.schema_name, m.json));
    }
    for d in &run.deliveries {
        let key = keys.robot_obs(&d.obs.robot_id)?;
        out.push((d.arrival, key, "Observation", proto::encode(&d.obs)));
    }
    // Stable: truth before observations at equal times, each in its own order.
    out.sort_by_key(|m| m.0);
    for (at, topic, schema, payload) in &out {
        sink.write(topic, schema, *at, payload);
    }
    Ok(out.len())
}

/// The run a log holds: its ground truth, and its observations at the times they were
/// logged. `None` when the log carries no ground truth.
pub fn run_of_log(messages: &[LogMessage]) -> Result<Option<SimRun>, TruthLogError> {
    let mut truth = TruthLogBuilder::new();
    let mut arrivals = Vec::new();
    for m in messages {
        if sim::TRUTH_TOPICS.contains(&m.topic.as_str()) {
            truth.push(&m.topic, &m.data)?;
        } else if m.schema_name == "Observation"
            && let Ok(o) = proto::decode::<proto::Observation>(&m.data)
        {
            arrivals.push((m.log_time, o));
        }
    }
    if !truth.has_run() {
        return Ok(None);
    }
    truth.finish(arrivals).map(Some)
}

/// The evaluation's figures for the fusion core (configured by `cfg`, on the run's pitch)
/// over a run read back from a log.
pub fn score_run(run: &SimRun, cfg: &FusionConfig) -> Summary {
    let mut cfg = cfg.clone();
    cfg.set_pitch(run.pitch.clone());
    let records = run_fusion(run, cfg.clone(), |_| true);
    let without = run
        .phantom
        .as_ref()
        .map(|_| run_fusion(run, cfg.clone(), |d: &Delivery| d.kind != ObsKind::Phantom));
    let samples = score(
        run,
        &records,
        tick_count(run.duration_s),
        without.as_deref(),
    );
    Summary::of(&samples)
}

/// The summary as text, a line per figure.
pub fn summary_text(acc: &Summary) -> String {
    let f = |v: Option<f64>, scale: f64, unit: &str| {
        v.map(|x| format!("{:.1} {unit}", x * scale))
            .unwrap_or_else(|| "-".into())
    };
    let spread = |sp: &Spread, scale: f64, unit: &str| {
        format!(
            "median {} / p90 {}",
            f(sp.median, scale, unit),
            f(sp.p90, scale, unit)
        )
    };
    let mut lines = vec![
        "accuracy against the log's ground truth (the evaluation's figures):".to_string(),
        format!(
            "  coverage            {}",
            f(Some(acc.coverage), 100.0, "%")
        ),
        format!(
            "  position score      {}",
            f(acc.position_score, 100.0, "%")
        ),
        format!(
            "  position RMSE       {}",
            f(acc.position_rmse_m, 100.0, "cm")
        ),
        format!(
            "  position median     {}",
            f(acc.position_median_m, 100.0, "cm")
        ),
        format!(
            "  velocity RMSE       {}",
            f(acc.velocity_rmse_mps, 100.0, "cm/s")
        ),
        format!(
            "  direction error     {}",
            f(acc.direction_error_deg, 1.0, "deg")
        ),
    ];
    for (h, sp) in &acc.horizon_error_m {
        lines.push(format!(
            "  error at {h:>4} s     {}",
            spread(sp, 100.0, "cm")
        ));
    }
    lines.push(format!(
        "  stop point error    {}",
        spread(&acc.stop_error_m, 100.0, "cm")
    ));
    lines.push(format!(
        "  bounce time error   {}",
        spread(&acc.bounce_time_error_s, 1000.0, "ms")
    ));
    if let Some(p) = acc.phantom_pull_max_m {
        lines.push(format!("  phantom pull max    {:.1} cm", p * 100.0));
    }
    lines.join("\n")
}

//! `simulate`: a simulated match written as a match log (MCAP): every observation on its
//! robot's key at the time it reaches the server, and the simulator's ground truth on
//! channels of their own; and, as the server would have made them, the fused ball's states
//! and the match drawn for Foxglove. `fusion-server replay` re-fuses it; `score_log` scores it.

use crate::sim_args::MatchArgs;
use crate::sim_log::{truth_schemas, write_simulated};
use anyhow::Result;
use clap::Parser;
use fusion_server::PitchFlags;
use fusion_server::RecorderConfig;
use fusion_server::RecorderSink;
use fusion_server::remove_earlier;
use fusion_server::{EngineConfig, LogMessage, ReplayOptions, ReplaySink};
use proto::{KeySpace, Stamp};
use std::path::PathBuf;

#[derive(Debug, Parser)]
#[command(about = "Simulate a match and write it as a match log (observations and ground truth)")]
struct Args {
    #[command(flatten)]
    sim: MatchArgs,
    /// The simulated pitch (replay it with the same flags).
    #[command(flatten)]
    pitch: PitchFlags,
    /// Directory for the log file.
    #[arg(long, default_value = "out/logs", help_heading = "Output")]
    out: PathBuf,
}

/// Messages kept in memory, in the order written.
#[derive(Debug, Default)]
struct Collected(Vec<LogMessage>);

impl ReplaySink for Collected {
    fn write(&mut self, topic: &str, schema: &str, log_time: Stamp, payload: &[u8]) {
        self.0.push(LogMessage {
            topic: topic.to_string(),
            schema_name: schema.to_string(),
            log_time,
            publish_time: log_time,
            data: payload.to_vec(),
        });
    }
}

pub fn main() -> Result<()> {
    let a = Args::parse();
    let pitch = a.pitch.over(&proto::Pitch::default())?;
    let run = a
        .sim
        .simulate(&pitch, a.sim.start_or(sim::SimConfig::default().start))?;
    let mut cfg = RecorderConfig::new(&a.out);
    cfg.file_prefix = format!("sim-{}-{}", a.sim.scenario, a.sim.seed);
    // The same scenario and seed make the same file: replace an earlier one.
    remove_earlier(&a.out, &cfg.file_prefix)?;
    let mut sink = RecorderSink::with_schemas(cfg, run.start, truth_schemas())?;
    // The simulated messages, then fused as the server would have: the log gets the ball's
    // states and the match drawn for Foxglove (its layout opens on them) beside them.
    let mut simulated = Collected::default();
    write_simulated(&run, &KeySpace::default(), &mut simulated)?;
    let mut engine = EngineConfig::default();
    engine.fusion.set_pitch(pitch.clone());
    let opts = ReplayOptions {
        engine,
        scene: true,
        ..ReplayOptions::default()
    };
    let report = fusion_server::replay(&simulated.0, &opts, &mut sink, &mut |_, _| {})?;
    let n = report.messages;
    let summary = sink.finish()?;
    for f in &summary.files {
        println!("{}", f.display());
    }
    eprintln!(
        "{} s of `{}` (seed {}): {} observations from {} robots, {n} messages",
        run.duration_s,
        run.scenario,
        run.seed,
        run.deliveries.len(),
        run.observer_ids().len()
    );
    Ok(())
}

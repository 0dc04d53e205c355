//! `sim_agent`: the robot agent on the simulator's rendered cameras. The agent's own
//! runtime (`robot_agent::run_agent`, the loop `robot-agent run` runs) with the frames
//! of a simulated match seen through one robot's two cameras; the detection is scored
//! against the renderer's truth outside the agent.
//!
//! Flags (those of `robot-agent run`, and the simulated match's):
//! - `--robot-id ID` (required), `--source sim` (the only source, the default),
//!   `--detector NAME`, `--model FILE`, `--calibration FILE`, `--calibration-right FILE`,
//!   `--rescale-calibration`, `--config FILE`;
//! - Zenoh: `--connect ENDPOINT…`, `--listen ENDPOINT…`, `--mode peer|client|router`,
//!   `--prefix PREFIX` (default `rf`);
//! - the loop: `--fast`, `--restamp`, `--offline`, `--duration S`, `--record-frames
//!   FILE.mcap|DIR`, `--status-hz HZ` (default 2), `--parent-pid PID` (stop when the
//!   launcher is gone);
//! - the match: `--scenario NAME` (default `match`), `--seed N` (default 1),
//!   `--team-size N`, `--duration-s S`, `--start-ns NS` (the match's t = 0, default
//!   now), `--patterned-ball`, `--camera-hz HZ` (default 15), `--repeat` (the next seed's
//!   match after each one);
//! - accepted and unused, as `robot-agent run` takes them: `--ros-key-prefix` and the ROS
//!   topic flags.
//!
//! A leading `run` (`sim_agent run --robot-id …`, the way `robot-agent run` was called for
//! the simulated cameras) is accepted and ignored.
//!
//! Output, as `robot-agent run --source sim` printed it. Standard output at the end:
//! `ID: N frames, M observations; pipeline per frame median X ms, p99 Y ms` (or `ID: 0
//! frames, 0 observations`), `ID: K frames skipped because the pipeline fell behind` when
//! some were, then `against the simulator's truth: ball visible in V frames, found in H
//! (recall R %), F false sightings (precision P %)` and one `  missed: WHY: N` line per
//! reason. Standard error (tracing, `RUST_LOG`, default `info,zenoh=error`): `ID: publishing
//! on KEY and KEY` when online, a progress line every 5 s (`ID: N frames, M observations,
//! pipeline median X ms/frame, rejected {…}`), `ID: next match, seed N` with `--repeat`.

use crate::agent_recall::scoring_hook;
use crate::sim_source::{SimArgs, SimSource};
use anyhow::{Result, bail};
use clap::Parser;
use robot_agent::{RunArgs, Source, wall_now};

#[derive(Debug, Parser)]
#[command(
    name = "sim_agent",
    about = "The robot agent on the simulator's rendered cameras"
)]
struct Args {
    /// The frame source: `sim` (the simulator's rendered cameras) is the only one.
    #[arg(long, default_value = "sim")]
    source: String,
    #[command(flatten)]
    run: RunArgs,
    #[command(flatten)]
    sim: SimArgs,
}

pub fn main() -> Result<()> {
    let mut argv: Vec<std::ffi::OsString> = std::env::args_os().collect();
    if argv.get(1).is_some_and(|a| a == "run") {
        argv.remove(1);
    }
    let args = Args::parse_from(argv);
    robot_agent::cli::init_logging();
    if args.source != "sim" {
        bail!(
            "source {:?}: sim_agent renders the simulator's cameras (`--source sim`); \
             `robot-agent run` takes images:DIR, mcap:FILE and zenoh:…",
            args.source
        );
    }
    anyhow::ensure!(
        proto::is_valid_id(&args.run.robot_id),
        "robot id {:?} is not valid",
        args.run.robot_id
    );
    let source = SimSource::new(&args.run.robot_id, &args.sim, wall_now())?;
    let (hook, recall) = scoring_hook(source.truths());
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()?;
    rt.block_on(robot_agent::run_agent(
        args.run,
        Source::Given(Box::new(source)),
        Some(hook),
    ))?;
    let recall = recall
        .lock()
        .map_err(|_| anyhow::anyhow!("the scoring hook panicked"))?;
    for line in recall.lines() {
        println!("{line}");
    }
    Ok(())
}

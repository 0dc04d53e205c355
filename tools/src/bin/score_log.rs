//! `score_log`: a match log that carries the simulator's ground truth (written by
//! `simulate`) scored the way the evaluation scores a run: the fusion core, configured as
//! the server would be, fed the logged observations at their logged arrival times.

use anyhow::{Context, Result};
use clap::Parser;
use fusion_server::read_logs;
use fusion_server::{ServeArgs, serve_config};
use std::path::PathBuf;
use tools::sim_log::{run_of_log, score_run, summary_text};

#[derive(Debug, Parser)]
#[command(about = "Score the fusion core on a simulated match log against its ground truth")]
struct Args {
    /// Match log files of one match, in order.
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Print the figures as JSON.
    #[arg(long)]
    json: bool,
    /// The server's settings (`--config`, pitch flags) the fusion core runs with.
    #[command(flatten)]
    serve: ServeArgs,
}

fn main() -> Result<()> {
    let a = Args::parse();
    let (cfg, _) = serve_config(&a.serve)?;
    let log = read_logs(&a.files)?;
    if !log.complete {
        eprintln!(
            "warning: log incomplete ({}); scoring the {} messages before the damage",
            log.problem.as_deref().unwrap_or("no footer"),
            log.messages.len()
        );
    }
    let run = run_of_log(&log.messages)
        .context("reading the log's ground truth")?
        .context("the log carries no ground truth (only `simulate` writes it)")?;
    let summary = score_run(&run, &cfg.engine.fusion);
    if a.json {
        println!("{}", serde_json::to_string(&summary)?);
    } else {
        println!("{}", summary_text(&summary));
    }
    Ok(())
}

//! `sim_track`: a simulated run's ground truth as a ball-track CSV (`t_s,x_m,y_m`, with a
//! `# source:` line saying it is simulated), the format `evaluate --tracks` reads. For
//! sample data and for trying the tracks evaluation without a recording.

use anyhow::Context;
use clap::Parser;
use harness::track_fixtures::{sim_source, sim_track};
use harness::tracks::to_csv;
use std::path::PathBuf;

#[derive(Debug, Parser)]
#[command(about = "Write a simulated run's ball ground truth as a track CSV")]
struct Args {
    /// Scenario name (see `evaluate --scenarios`).
    #[arg(long, default_value = "team-rally")]
    scenario: String,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Overrides the scenario's length.
    #[arg(long)]
    duration_s: Option<f64>,
    /// The CSV file to write.
    #[arg(long)]
    out: PathBuf,
}

fn main() {
    if let Err(e) = run(Args::parse()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run(args: Args) -> anyhow::Result<()> {
    let cfg = sim::SimConfig {
        duration_s: args.duration_s,
        ..sim::SimConfig::default()
    };
    let run = sim::run_scenario(&args.scenario, args.seed, &cfg)?;
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let csv = to_csv(&sim_track(&run), &sim_source(&run));
    std::fs::write(&args.out, csv).with_context(|| format!("writing {}", args.out.display()))?;
    eprintln!(
        "wrote {} ({} samples, {} wall bounces in the truth)",
        args.out.display(),
        run.truth.len(),
        run.bounce_count()
    );
    Ok(())
}

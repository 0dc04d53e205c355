//! `sim_track`: a simulated run's ground truth as a ball-track CSV (`t_s,x_m,y_m`, with a
//! `# source:` line saying it is simulated), the format `evaluate --tracks` reads. For
//! sample data and for trying the tracks evaluation without a recording. `--case NAME`
//! writes one of the synthetic regression tracks instead (`relocations`, `puck`: motion the
//! scenarios lack; see `tools::track_cases`).

use anyhow::Context;
use clap::Parser;
use std::path::PathBuf;
use tools::track_fixtures::{sim_source, sim_track};
use tools::tracks::to_csv;

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
    /// A synthetic regression case instead of a scenario: `relocations` (a ball picked up
    /// and put down elsewhere between kicks, two-phase slide and roll, 9 m × 6 m),
    /// `kick-on-arrival` (the same, each ball kicked as it is put down), `hard-kicks` (kicks
    /// at 3–7 m/s on a 9.6 m × 6.6 m pitch, a longer slide and a speed-dependent roll),
    /// `puck` (a nearly frictionless puck on a 2 m × 1 m table, many bounces),
    /// `puck-hits` (the same table, struck every 0.3–1.5 s) or `puck-mallets` (a puck
    /// pushed by mallets that may hide it, drag, uneven rails and a tracker's jitter).
    #[arg(long, conflicts_with_all = ["scenario", "duration_s"])]
    case: Option<String>,
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
    if let Some(name) = &args.case {
        let c = tools::track_cases::case(name, args.seed).with_context(|| {
            format!(
                "no case {name:?}; the cases are {}",
                tools::track_cases::CASES.join(", ")
            )
        })?;
        write(&args.out, &to_csv(&c.samples, &c.source))?;
        eprintln!(
            "wrote {} ({} samples; evaluate it with --pitch {})",
            args.out.display(),
            c.samples.len(),
            c.pitch
        );
        return Ok(());
    }
    let cfg = sim::SimConfig {
        duration_s: args.duration_s,
        ..sim::SimConfig::default()
    };
    let run = sim::run_scenario(&args.scenario, args.seed, &cfg)?;
    write(&args.out, &to_csv(&sim_track(&run), &sim_source(&run)))?;
    eprintln!(
        "wrote {} ({} samples, {} wall bounces in the truth)",
        args.out.display(),
        run.truth.len(),
        run.bounce_count()
    );
    Ok(())
}

fn write(out: &std::path::Path, csv: &str) -> anyhow::Result<()> {
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(out, csv).with_context(|| format!("writing {}", out.display()))
}

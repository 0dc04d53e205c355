//! Fuzzes every decoder and validator of the products with deterministic, seeded inputs.
//!
//! `fuzz --inputs 1000000 --seed 1 [--target NAME]` runs that many inputs per target (or
//! only NAME's); a panic prints the target, seed, input index and the input, and makes the
//! command exit non-zero once every target has run.

use anyhow::{Result, bail};
use bench::fuzz::{self, runner};
use clap::Parser;
use tools::progress::Progress;

#[derive(Debug, Parser)]
#[command(about = "Fuzz the products' decoders and validators")]
struct Args {
    /// Inputs per target.
    #[arg(long, default_value_t = 100_000)]
    inputs: u64,
    /// Seed of the input streams (each target derives its own from it).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Only this target (repeatable); every target when omitted.
    #[arg(long)]
    target: Vec<String>,
}

fn main() {
    if let Err(e) = run(Args::parse()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run(args: Args) -> Result<()> {
    let names = fuzz::target_names();
    if let Some(unknown) = args.target.iter().find(|t| !names.contains(&t.as_str())) {
        bail!("unknown target {unknown:?}; targets: {}", names.join(", "));
    }
    let mut targets: Vec<_> = fuzz::all_targets()
        .into_iter()
        .filter(|t| args.target.is_empty() || args.target.iter().any(|n| n == t.name))
        .collect();
    let steps = runner::progress_steps(args.inputs) * targets.len() as u64;
    let progress = Progress::new(steps, "fuzz");
    let mut all_stats = Vec::new();
    let mut panics = 0;
    for target in &mut targets {
        let (stats, findings) = runner::run(target, args.seed, args.inputs, &progress);
        for f in &findings {
            progress.suspend(|| eprintln!("{}", f.report()));
        }
        panics += stats.panics;
        all_stats.push(stats);
    }
    progress.finish();
    print_table(&all_stats);
    if panics > 0 {
        bail!("{panics} inputs made a target panic");
    }
    Ok(())
}

fn print_table(stats: &[runner::Stats]) {
    println!(
        "{:<20} {:>10} {:>10} {:>10} {:>7} {:>9} {:>11}",
        "target", "inputs", "accepted", "rejected", "panics", "time_s", "inputs/s"
    );
    for s in stats {
        println!(
            "{:<20} {:>10} {:>10} {:>10} {:>7} {:>9.1} {:>11.0}",
            s.target,
            s.inputs,
            s.accepted,
            s.rejected,
            s.panics,
            s.elapsed.as_secs_f64(),
            s.inputs_per_s()
        );
    }
    let inputs: u64 = stats.iter().map(|s| s.inputs).sum();
    let secs: f64 = stats.iter().map(|s| s.elapsed.as_secs_f64()).sum();
    println!(
        "{:<20} {:>10} {:>43.1} {:>11.0}",
        "total",
        inputs,
        secs,
        inputs as f64 / secs.max(1e-9)
    );
}

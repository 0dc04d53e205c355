//! `bench_views`: what the robots' camera views cost. A `fusion-server` process recording
//! a match log and `--robots` `sim_agent` processes playing one simulated match on their
//! rendered cameras, run twice: with views at `--view-hz` per camera and without. Each run
//! measures the server's CPU, each view's delay from capture to the page's view stream
//! (`/api/views/stream`), and the match log's size a minute.
//!
//! Flags: `--robots N` (default 5), `--view-hz HZ` (default 2), `--camera-hz HZ` (default
//! 10, both cameras), `--seconds S` (default 30), `--warmup-s S` (default 8), `--seed N`,
//! `--server FILE`, `--agent FILE` (default: beside this program), `--doc FILE` and
//! `--section NAME` (default `bench-views`).
//!
//! `cargo build --release -p fusion-server -p tools --bins && cargo run --release -p bench --bin bench_views -- --doc docs/benchmarks.md`

use anyhow::{Context, Result};
use bench::views_bench::{ViewsConfig, log_dir, run, table};
use clap::Parser;
use std::path::PathBuf;

#[derive(Debug, Parser)]
#[command(about = "What the robots' camera views cost the server, the page and the match log")]
struct Args {
    #[arg(long, default_value_t = 5)]
    robots: usize,
    #[arg(long, default_value_t = 2.0)]
    view_hz: f64,
    #[arg(long, default_value_t = 10.0)]
    camera_hz: f64,
    #[arg(long, default_value_t = 30.0)]
    seconds: f64,
    #[arg(long, default_value_t = 8.0)]
    warmup_s: f64,
    #[arg(long, default_value_t = 3)]
    seed: u64,
    /// The server binary [default: `fusion-server` beside this one].
    #[arg(long)]
    server: Option<PathBuf>,
    /// The agent binary [default: `sim_agent` beside this one].
    #[arg(long)]
    agent: Option<PathBuf>,
    /// Rewrite a section of this file with the table.
    #[arg(long)]
    doc: Option<PathBuf>,
    /// The section `--doc` rewrites (between `<!-- NAME:begin -->` and `<!-- NAME:end -->`).
    #[arg(long, default_value = "bench-views")]
    section: String,
}

fn beside(name: &str, given: Option<PathBuf>, build: &str) -> Result<PathBuf> {
    let path = match given {
        Some(p) => p,
        None => std::env::current_exe()?
            .parent()
            .context("this program's folder")?
            .join(format!("{name}{}", std::env::consts::EXE_SUFFIX)),
    };
    anyhow::ensure!(
        path.is_file(),
        "no {name} at {} (build it: {build})",
        path.display()
    );
    Ok(path)
}

fn main() -> Result<()> {
    let a = Args::parse();
    let server = beside(
        "fusion-server",
        a.server.clone(),
        "cargo build --release -p fusion-server",
    )?;
    let agent = beside(
        "sim_agent",
        a.agent.clone(),
        "cargo build --release -p tools --bins",
    )?;
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()?;
    let mut runs = Vec::new();
    for view_hz in [a.view_hz, 0.0] {
        eprintln!(
            "{} agents, views at {view_hz} a second per camera: {} s warm-up, {} s measured…",
            a.robots, a.warmup_s, a.seconds
        );
        let cfg = ViewsConfig {
            robots: a.robots,
            view_hz,
            camera_hz: a.camera_hz,
            seconds: a.seconds,
            seed: a.seed,
        };
        let dir = log_dir(&format!("{view_hz}"));
        let report = rt.block_on(run(&server, &agent, &dir, &cfg, a.warmup_s))?;
        let _ = std::fs::remove_dir_all(&dir);
        eprintln!("{}", serde_json::to_string(&report)?);
        runs.push(report);
    }
    let t = table(&runs);
    print!("{t}");
    if let Some(doc) = &a.doc {
        let command = format!(
            "cargo run --release -p bench --bin bench_views -- --robots {} --view-hz {} --camera-hz {} --seconds {} --section {} --doc {}",
            a.robots,
            a.view_hz,
            a.camera_hz,
            a.seconds,
            a.section,
            doc.display()
        );
        let body = format!(
            "Produced by `{command}` (the server, {} `sim_agent` processes rendering a simulated match and a client of the view stream, all on this 2-core machine).\n\n{t}",
            a.robots
        );
        eval::report::rewrite_section_between(
            doc,
            &format!("<!-- {}:begin -->", a.section),
            &format!("<!-- {}:end -->", a.section),
            &body,
        )?;
    }
    Ok(())
}

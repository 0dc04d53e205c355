//! `load_test`: a `fusion-server` process fed by many simulated robots at once, each with
//! its own Zenoh session and liveliness token, every camera publishing at a fixed rate over
//! loopback. Reports whether everything sent was received and accepted (from the server's
//! `/metrics`), the arrival-to-state latency, the states published, and the server
//! process's memory and CPU time (from `/proc`).
//!
//! Prints a markdown table; `--json FILE` keeps the figures, `--doc FILE` rewrites the
//! generated section of docs/benchmarks.md.

use anyhow::{Context, Result};
use bench::load::{self, LoadConfig};
use clap::Parser;
use std::path::PathBuf;
use tools::progress::Progress;

#[derive(Debug, Parser)]
struct Args {
    #[arg(long, default_value_t = 100)]
    robots: usize,
    /// Cameras per robot.
    #[arg(long, default_value_t = 2)]
    cameras: usize,
    /// Observations per second per camera.
    #[arg(long, default_value_t = 30.0)]
    hz: f64,
    #[arg(long, default_value_t = 60.0)]
    seconds: f64,
    /// Robots sharing one Zenoh session (1: a session each, as on the real robots).
    #[arg(long, default_value_t = 1)]
    robots_per_session: usize,
    /// Robots wait for room in Zenoh's send queue instead of dropping (the agent drops):
    /// any loss left is the server's.
    #[arg(long)]
    block: bool,
    /// A secured network: TLS with mutual authentication, a certificate per robot, the
    /// roster's access-control list (its table goes between the load-test-tls markers).
    #[arg(long)]
    tls: bool,
    /// A load beyond the server's capacity on purpose (say 100 robots × 2 cameras × 300 Hz):
    /// losses are expected and reported, not an error; `--doc` fills the overload section.
    #[arg(long)]
    overload: bool,
    /// The section of `--doc` to fill, `load-test-NAME` (default: by the kind of run:
    /// `load-test`, `load-test-tls` or `load-test-overload`).
    #[arg(long)]
    section: Option<String>,
    /// The server binary [default: `fusion-server` beside this one].
    #[arg(long)]
    server: Option<PathBuf>,
    #[arg(long)]
    json: Option<PathBuf>,
    #[arg(long)]
    doc: Option<PathBuf>,
}

/// Where `--doc` puts the table: a section named by `--section`, else one for the open
/// network, one for TLS, one for the overload.
fn markers(args: &Args) -> (String, String) {
    let name = match &args.section {
        Some(s) => format!("load-test-{s}"),
        None if args.overload => "load-test-overload".into(),
        None if args.tls => "load-test-tls".into(),
        None => "load-test".into(),
    };
    (
        format!("<!-- {name}:begin -->"),
        format!("<!-- {name}:end -->"),
    )
}

fn main() {
    if let Err(e) = run(Args::parse()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run(args: Args) -> Result<()> {
    anyhow::ensure!(
        args.robots > 0 && args.cameras > 0 && args.hz > 0.0 && args.seconds > 0.0,
        "robots, cameras, hz and seconds must be positive"
    );
    let server = match args.server.clone() {
        Some(s) => s,
        None => std::env::current_exe()?
            .parent()
            .context("this binary's folder")?
            .join(format!("fusion-server{}", std::env::consts::EXE_SUFFIX)),
    };
    anyhow::ensure!(
        server.is_file(),
        "no server binary at {} (build it: cargo build --release -p fusion-server)",
        server.display()
    );
    let cfg = LoadConfig {
        robots: args.robots,
        cameras: args.cameras,
        hz: args.hz,
        seconds: args.seconds,
        robots_per_session: args.robots_per_session,
        block: args.block,
        tls: args.tls,
        ..LoadConfig::default()
    };
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()?;
    let progress = Progress::new(args.seconds.ceil() as u64, "seconds of load");
    let report = rt.block_on(load::run(&server, &cfg, &progress))?;
    progress.finish();
    let mut command = format!(
        "cargo run --release -p bench --bin load_test -- --robots {} --hz {} --cameras {} --seconds {}",
        args.robots, args.hz, args.cameras, args.seconds
    );
    if args.robots_per_session != 1 {
        command.push_str(&format!(
            " --robots-per-session {}",
            args.robots_per_session
        ));
    }
    if args.block {
        command.push_str(" --block");
    }
    if args.tls {
        command.push_str(" --tls");
    }
    if args.overload {
        command.push_str(" --overload");
    }
    if let Some(s) = &args.section {
        command.push_str(&format!(" --section {s}"));
    }
    if let Some(p) = &args.doc {
        command.push_str(&format!(" --doc {}", p.display()));
    }
    let table = report.markdown(&command);
    println!("{table}");
    if let Some(p) = &args.json {
        eval::report::write_json(p, &report)?;
    }
    if let Some(p) = &args.doc {
        let (begin, end) = markers(&args);
        eval::report::rewrite_section_between(p, &begin, &end, &table)?;
    }
    anyhow::ensure!(
        args.overload || report.nothing_lost(),
        "observations were lost or rejected (see the table)"
    );
    Ok(())
}

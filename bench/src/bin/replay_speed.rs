//! `replay_speed`: how fast the fusion core takes a simulated match's observations, in
//! arrival order, compared with real time.

use clap::Parser;
use eval::methods::fusion_config;
use fusion_server::Fusion;
use std::time::Instant;

#[derive(Debug, Parser)]
struct Args {
    /// Match length in simulated seconds.
    #[arg(long, default_value_t = 600.0)]
    seconds: f64,
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

fn main() {
    let args = Args::parse();
    let cfg = sim::SimConfig {
        duration_s: Some(args.seconds),
        ..sim::SimConfig::default()
    };
    let started = Instant::now();
    let run = match sim::run_scenario("match", args.seed, &cfg) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    let sim_s = started.elapsed().as_secs_f64();
    let mut fusion = Fusion::new(fusion_config(&run));
    let started = Instant::now();
    for d in &run.deliveries {
        fusion.ingest(&d.obs, d.arrival);
    }
    let fuse_s = started.elapsed().as_secs_f64();
    let n = run.deliveries.len() as f64;
    println!(
        "{} observations from {} robots over {:.0} s simulated in {:.2} s; fused in {:.3} s: {:.0} observations/s, {:.0}× real time",
        run.deliveries.len(),
        run.observer_ids().len(),
        run.duration_s,
        sim_s,
        fuse_s,
        n / fuse_s,
        run.duration_s / fuse_s
    );
    println!("{:?}", fusion.counters());
}

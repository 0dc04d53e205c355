//! `trace`: one scenario and seed, tick by tick: truth, the fused estimate and its error,
//! as CSV on stdout, for looking into where the error comes from.

use clap::Parser;
use fusion_server::core::Fusion;
use system_tests::methods::{TICK_S, fusion_config};

#[derive(Debug, Parser)]
struct Args {
    scenario: String,
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

fn main() {
    let args = Args::parse();
    let run = match sim::run_scenario(&args.scenario, args.seed, &sim::SimConfig::default()) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    for e in &run.events {
        eprintln!("event {e:?}");
    }
    let mut fusion = Fusion::new(fusion_config(&run));
    let mut next = 0;
    println!(
        "t_s,true_x,true_y,true_vx,true_vy,est_x,est_y,est_vx,est_vy,err_m,tracks,decel,restitution"
    );
    let n = (run.duration_s / TICK_S) as usize;
    for k in 1..=n {
        let t = k as f64 * TICK_S;
        let at = run.stamp_of(t);
        while let Some(d) = run.deliveries.get(next).filter(|d| d.arrival <= at) {
            fusion.ingest(&d.obs);
            next += 1;
        }
        let truth = run.truth_at(t);
        if std::env::var_os("TRACE_TRACKS").is_some() {
            let tr = fusion.tracker();
            for (i, track) in tr.tracks().iter().enumerate() {
                let f = &track.filter;
                eprintln!(
                    "{t:.2} track {} main={} p=({:.2},{:.2}) v=({:.2},{:.2}) hits={} robots={:?} last={:.2} sd=({:.3},{:.3})",
                    track.id,
                    tr.main().is_some_and(|m| m.id == track.id),
                    f.x[0],
                    f.x[1],
                    f.x[2],
                    f.x[3],
                    track.recent_hits(tr.t_s, 0.4),
                    track.contributors(tr.t_s, 0.4),
                    track.last_hit_s - 0.0 * i as f64,
                    f.p[(0, 0)].sqrt(),
                    f.p[(2, 2)].sqrt(),
                );
            }
        }
        let Some(f) = fusion.filter_at(at) else {
            continue;
        };
        let (p, v) = (f.position(), f.velocity());
        let err = (p[0] - truth.position_m[0]).hypot(p[1] - truth.position_m[1]);
        println!(
            "{t:.2},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{err:.3},{},{:.3},{:.3}",
            truth.position_m[0],
            truth.position_m[1],
            truth.velocity_mps[0],
            truth.velocity_mps[1],
            p[0],
            p[1],
            v[0],
            v[1],
            fusion.tracker().tracks().len(),
            f.x[4],
            f.x[5]
        );
    }
    eprintln!("{:?}", fusion.counters());
    for r in fusion.robots() {
        eprintln!(
            "{} scale {:.2} outliers {:.3} obs {}",
            r.robot, r.covariance_scale, r.outlier_rate, r.observations
        );
    }
}

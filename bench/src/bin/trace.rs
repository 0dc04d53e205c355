//! `trace`: one scenario and seed, tick by tick: truth, the fused estimate and its error,
//! as CSV on stdout, for looking into where the error comes from.

use clap::Parser;
use eval::methods::fusion_config;
use fusion_server::Fusion;
use sim::TICK_S;

#[derive(Debug, Parser)]
struct Args {
    scenario: String,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Also list every delivery (capture time, arrival, robot, kind, position) on stderr.
    #[arg(long)]
    deliveries: bool,
    /// Withhold the phantom reports (to see what the phantom changes).
    #[arg(long)]
    without_phantom: bool,
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
    if args.deliveries {
        for d in &run.deliveries {
            eprintln!(
                "obs t={:.3} arrival={:.3} {} {:?} ({:.2}, {:.2})",
                run.t_of(d.obs.stamp),
                run.t_of(d.arrival),
                d.obs.robot_id,
                d.kind,
                d.obs.position_m[0],
                d.obs.position_m[1]
            );
        }
    }
    for e in &run.events {
        eprintln!("event {e:?}");
    }
    let mut fusion = Fusion::new(fusion_config(&run));
    let mut next = 0;
    // Velocity errors while the ball moves, split by whether a kick, bounce or contact
    // happened within the last 0.6 s.
    let mut after_event = Vec::new();
    let mut settled = Vec::new();
    println!(
        "t_s,true_x,true_y,true_vx,true_vy,est_x,est_y,est_vx,est_vy,err_m,tracks,decel,restitution"
    );
    let n = (run.duration_s / TICK_S) as usize;
    for k in 1..=n {
        let t = k as f64 * TICK_S;
        let at = run.stamp_of(t);
        while let Some(d) = run.deliveries.get(next).filter(|d| d.arrival <= at) {
            if !(args.without_phantom && d.kind == sim::ObsKind::Phantom) {
                fusion.ingest(&d.obs, d.arrival);
            }
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
                    f.state()[0],
                    f.state()[1],
                    f.state()[2],
                    f.state()[3],
                    track.recent_hits(tr.t_s, 0.4),
                    track.contributors(tr.t_s, 0.4),
                    track.last_hit_s - 0.0 * i as f64,
                    f.covariance()[(0, 0)].sqrt(),
                    f.covariance()[(2, 2)].sqrt(),
                );
            }
        }
        let Some(f) = fusion.filter_at(at) else {
            continue;
        };
        let (p, v) = (f.position(), f.velocity());
        let err = (p[0] - truth.position_m[0]).hypot(p[1] - truth.position_m[1]);
        let tv = truth.velocity_mps;
        if tv[0].hypot(tv[1]) > 0.05 {
            let verr = (v[0] - tv[0]).hypot(v[1] - tv[1]);
            let recent = run.events.iter().any(|e| {
                let dt = t - e.t_s();
                (0.0..0.6).contains(&dt) && !matches!(e, sim::BallEvent::Stopped { .. })
            });
            if recent {
                after_event.push(verr);
            } else {
                settled.push(verr);
            }
        }
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
            f.state()[4],
            f.state()[5]
        );
    }
    eprintln!("{:?}", fusion.counters());
    eprintln!(
        "median velocity error while moving: {} within 0.6 s of a kick, bounce or contact, {} otherwise",
        median_text(&mut after_event),
        median_text(&mut settled)
    );
    if let Some(st) = fusion.ball_state(run.stamp_of(run.duration_s)) {
        eprintln!(
            "learned decel {:.3} m/s² (true rolling {:.3}), restitution {:.3} (true mean {:.3}), from {} observations and {} bounces",
            st.model.rolling_decel_mps2,
            run.params.rolling_decel_mps2,
            st.model.wall_restitution,
            run.params.restitution_mean,
            st.model.decel_samples,
            st.model.restitution_samples
        );
    }
    // How far each robot's believed pose was from its true pose, on average over its reports.
    for robot in &run.robots {
        let reports: Vec<_> = run
            .deliveries
            .iter()
            .filter(|d| d.obs.robot_id == robot.id)
            .collect();
        if reports.is_empty() {
            continue;
        }
        let n = reports.len() as f64;
        let mut sum = [0.0; 3];
        for d in &reports {
            let truth = robot.pose_at(run.t_of(d.obs.stamp));
            sum[0] += d.obs.robot_pose.x_m - truth.x_m;
            sum[1] += d.obs.robot_pose.y_m - truth.y_m;
            sum[2] += d.obs.robot_pose.theta_rad - truth.theta_rad;
        }
        eprintln!(
            "{} mean pose error: x {:+.3} m, y {:+.3} m, theta {:+.4} rad over {} reports",
            robot.id,
            sum[0] / n,
            sum[1] / n,
            sum[2] / n,
            reports.len()
        );
    }
    for r in fusion.robots() {
        eprintln!(
            "{} scale {:.2} outliers {:.3} obs {}",
            r.robot, r.covariance_scale, r.outlier_rate, r.observations
        );
    }
}

fn median_text(v: &mut [f64]) -> String {
    match proto::stats::median(v) {
        Some(m) => format!("{m:.3} m/s (n = {})", v.len()),
        None => "n/a".to_string(),
    }
}

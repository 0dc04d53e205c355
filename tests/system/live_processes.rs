//! End to end over real processes: a server and simulated MiRos, each its own process,
//! talking Zenoh over loopback; the test reads the server's HTTP API.

mod support;

use proto::Stamp;
use std::time::{Duration, Instant};
use support::*;

const SCENARIO: &str = "match";
const SEED: u64 = 3;
const MATCH_S: f64 = 24.0;

fn robot_online(addr: &str, id: &str) -> Option<bool> {
    let robots = get_json(addr, "/api/robots");
    robots
        .as_array()?
        .iter()
        .find(|r| r["robot_id"] == id)
        .and_then(|r| r["online"].as_bool())
}

#[test]
fn server_follows_the_simulated_ball_and_notices_a_robot_dying() {
    let (_server, endpoint, addr) = start_server(&["--id", "e2e"]);
    // Everyone plays the same match from a shared start a little ahead.
    let start = Stamp(now_ns()).offset_secs(3.0);
    let run =
        tools::sim_robots::simulate(SCENARIO, SEED, start, Some(MATCH_S), None).expect("simulate");
    let ids = tools::sim_robots::chosen_robots(&run, &[]).expect("robots");
    assert!(ids.len() >= 3, "{ids:?}");
    let start_ns = start.0.to_string();
    let duration = MATCH_S.to_string();
    let mut robots: Vec<Proc> = ids
        .iter()
        .map(|id| {
            Proc::robots(&[
                "--connect",
                &endpoint,
                "--scenario",
                SCENARIO,
                "--seed",
                &SEED.to_string(),
                "--only",
                id,
                "--duration-s",
                &duration,
                "--start-ns",
                &start_ns,
            ])
        })
        .collect();
    for id in &ids {
        wait_for("robots online", Duration::from_secs(20), || {
            robot_online(&addr, id).filter(|o| *o)
        });
    }

    // Follow the ball for a while: the served estimate against the simulated truth.
    let mut errors_m = Vec::new();
    let follow_until = start.offset_secs(14.0);
    while Stamp(now_ns()) < follow_until {
        let v = get_json(&addr, "/api/state");
        if let (Some(x), Some(y), Some(stamp)) = (
            v["ball"]["position_m"][0].as_f64(),
            v["ball"]["position_m"][1].as_f64(),
            v["ball"]["stamp"].as_u64(),
        ) {
            let t_s = Stamp(stamp).secs_since(start);
            if t_s > 2.0 {
                let truth = run.truth_at(t_s).position_m;
                errors_m.push((x - truth[0]).hypot(y - truth[1]));
            }
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    assert!(errors_m.len() > 50, "only {} samples", errors_m.len());
    errors_m.sort_by(f64::total_cmp);
    let median = errors_m[errors_m.len() / 2];
    let p90 = errors_m[errors_m.len() * 9 / 10];
    // The core's own accuracy is a few cm; these floors catch a broken pipeline.
    assert!(median < 0.10, "median error {median:.3} m");
    assert!(p90 < 0.30, "p90 error {p90:.3} m");

    // Kill one robot outright: its liveliness token must go within a second.
    let victim = ids[0].clone();
    let mut dead = robots.remove(0);
    dead.child.kill().expect("kill");
    let killed = Instant::now();
    wait_for("robot offline", Duration::from_secs(5), || {
        robot_online(&addr, &victim).filter(|o| !o)
    });
    let offline_after = killed.elapsed();
    assert!(
        offline_after < Duration::from_secs(1),
        "offline after {offline_after:?}"
    );
    // The others are still online and the metrics say so.
    for id in &ids[1..] {
        assert_eq!(robot_online(&addr, id), Some(true), "{id}");
    }
    let (code, metrics) = http_get(&addr, "/metrics").expect("metrics");
    assert_eq!(code, 200);
    assert!(metrics.contains(&format!("rf_robot_online{{robot=\"{victim}\"}} 0")));
    drop(robots);
}

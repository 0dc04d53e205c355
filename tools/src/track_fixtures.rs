//! A hand-made ball track for tests and examples: a roll with constant deceleration and
//! wall reflections that keep the tangential speed and scale the normal one, integrated in
//! small steps (the slow obvious reference), with its true bounce times.

use crate::tracks::TrackSample;
use fusion_server::Bounds;

/// A roll to make: from `start_m` at `velocity_mps`, slowing by `decel_mps2`, bouncing
/// off the walls of `bounds` with `restitution`, sampled at `rate_hz` for `duration_s`.
#[derive(Debug, Clone, PartialEq)]
pub struct Roll {
    pub start_m: [f64; 2],
    pub velocity_mps: [f64; 2],
    pub decel_mps2: f64,
    pub restitution: f64,
    pub rate_hz: f64,
    pub duration_s: f64,
    /// The ball rests here until `kick_at_s`, then starts rolling.
    pub kick_at_s: f64,
}

impl Default for Roll {
    fn default() -> Self {
        Roll {
            start_m: [-0.8, -0.4],
            velocity_mps: [1.6, 0.4],
            decel_mps2: 0.3,
            restitution: 0.6,
            rate_hz: 100.0,
            duration_s: 5.0,
            kick_at_s: 0.0,
        }
    }
}

const STEP_S: f64 = 1e-4;

impl Roll {
    /// The samples and the true wall bounce times.
    pub fn run(&self, bounds: &Bounds) -> (Vec<TrackSample>, Vec<f64>) {
        let (mut p, mut v) = (self.start_m, [0.0, 0.0]);
        let mut samples = Vec::new();
        let mut bounces = Vec::new();
        let n = (self.duration_s * self.rate_hz).round() as usize;
        let mut t = 0.0;
        let mut kicked = false;
        let lo = [bounds.x_min, bounds.y_min];
        let hi = [bounds.x_max, bounds.y_max];
        for k in 0..=n {
            let t_k = k as f64 / self.rate_hz;
            while t + STEP_S <= t_k + 1e-12 {
                if !kicked && t + STEP_S > self.kick_at_s {
                    v = self.velocity_mps;
                    kicked = true;
                }
                let speed = v[0].hypot(v[1]);
                let dv = self.decel_mps2 * STEP_S;
                if speed <= dv {
                    v = [0.0, 0.0];
                } else {
                    v = [v[0] * (1.0 - dv / speed), v[1] * (1.0 - dv / speed)];
                }
                for a in 0..2 {
                    p[a] += v[a] * STEP_S;
                    let wall = if p[a] > hi[a] {
                        Some(hi[a])
                    } else if p[a] < lo[a] {
                        Some(lo[a])
                    } else {
                        None
                    };
                    if let Some(w) = wall {
                        // Back to the contact, out with the normal speed scaled.
                        let overshoot_s = (p[a] - w) / v[a];
                        bounces.push(t + STEP_S - overshoot_s);
                        v[a] *= -self.restitution;
                        p[a] = w + v[a] * overshoot_s;
                    }
                }
                t += STEP_S;
            }
            samples.push(TrackSample {
                t_s: t_k,
                position_m: p,
            });
        }
        (samples, bounces)
    }
}

/// A simulated run's ground truth as a track: what `sim_track` writes.
pub fn sim_track(run: &sim::SimRun) -> Vec<TrackSample> {
    run.truth
        .iter()
        .map(|s| TrackSample {
            t_s: s.t_s,
            position_m: s.position_m,
        })
        .collect()
}

/// The `# source:` line of a simulated track: simulated, never to be taken for a recording.
pub fn sim_source(run: &sim::SimRun) -> String {
    format!(
        "SIMULATED, not a real recording: ground truth of this project's simulator (sim crate), \
         scenario {} seed {}, {:.0} s, written by `cargo run --release -p tools --bin sim_track -- \
         --scenario {} --seed {}`",
        run.scenario, run.seed, run.duration_s, run.scenario, run.seed
    )
}

//! The world: steps ball, robots and kicks on a fixed physics grid and lets the observers
//! capture in between, recording truth as it goes.
//!
//! Everything happens on the grid t = k·dt, and captures and truth samples are
//! interpolated between the two grid states around them, so the outcome does not depend on
//! how a caller slices time with `advance_to`: a live caller stepping every few ms gets
//! exactly the run a replay gets in one call.

use crate::kicks::{Director, View};
use crate::observer::{Observer, Scene};
use crate::physics::{Ball, Body, PhysEvent, Walls, robot_contacts, step};
use crate::rng::Rng;
use crate::robots::{ROBOT_RADIUS_M, Robot, ball_path, robot_limits, separate};
use crate::run::SimRun;
use crate::scenario::{ScenarioSpec, build};
use crate::types::{BallEvent, BallPhase, Delivery, RobotTrack, SimStats, TrueParams, TruthSample};
use crate::vec2::{V2, dist, lerp, lerp_angle, scale, sub};
use crate::{SimConfig, SimError, scenario_names};
use proto::Pose2;

/// A robot touching the ball again within this time is the same contact (pushing).
const CONTACT_DEBOUNCE_S: f64 = 0.25;
/// Phantom spots keep this far inside the ball's limits.
const PHANTOM_MARGIN_M: f64 = 0.15;

/// The simulated world of one scenario run, stepped incrementally.
#[derive(Debug, Clone)]
pub struct World {
    scenario: String,
    seed: u64,
    cfg: SimConfig,
    duration_s: f64,
    params: TrueParams,
    walls: Walls,
    robot_limit: V2,
    step_index: u64,
    ball: Ball,
    physics_rng: Rng,
    robots: Vec<Robot>,
    observers: Vec<Observer>,
    director: Director,
    /// False in the physics-only pre-run that places the phantom.
    observe: bool,
    truth: Vec<TruthSample>,
    next_truth: u64,
    poses: Vec<Vec<(f64, Pose2)>>,
    events: Vec<BallEvent>,
    pending: Vec<(f64, Delivery)>,
    last_contact_s: Vec<f64>,
    stats: SimStats,
    phantom: Option<(String, V2)>,
}

impl World {
    pub fn new(name: &str, seed: u64, cfg: &SimConfig) -> Result<World, SimError> {
        cfg.check()?;
        let params = TrueParams::draw(&mut Rng::stream(seed, "params", 0));
        let spec = build(
            name,
            &mut Rng::stream(seed, "scenario", 0),
            &params,
            &cfg.pitch,
            cfg.team_size,
        )
        .ok_or_else(|| SimError::UnknownScenario {
            name: name.to_string(),
            known: scenario_names(),
        })?;
        let duration_s = cfg.duration_s.unwrap_or(spec.duration_s);
        let mut world = World::from_spec(name, seed, cfg, params, &spec, duration_s);
        if let Some(i) = spec.phantom_robot {
            world.place_phantom(i);
        }
        Ok(world)
    }

    fn from_spec(
        name: &str,
        seed: u64,
        cfg: &SimConfig,
        params: TrueParams,
        spec: &ScenarioSpec,
        duration_s: f64,
    ) -> World {
        let walls = Walls::new(&cfg.pitch);
        let robots: Vec<Robot> = spec
            .robots
            .iter()
            .enumerate()
            .map(|(i, r)| {
                Robot::new(
                    r.id.clone(),
                    r.observer,
                    r.pose,
                    r.routine,
                    Rng::stream(seed, "robot", i as u64),
                )
            })
            .collect();
        let observers = make_observers(&robots, seed, cfg, spec);
        let ball = Ball::at_rest(walls.clamp(spec.ball));
        let t0 = TruthSample {
            t_s: 0.0,
            position_m: ball.pos,
            velocity_mps: [0.0, 0.0],
            phase: BallPhase::Rest,
        };
        World {
            scenario: name.to_string(),
            seed,
            cfg: cfg.clone(),
            duration_s,
            params,
            walls,
            robot_limit: robot_limits(&cfg.pitch),
            step_index: 0,
            ball,
            physics_rng: Rng::stream(seed, "physics", 0),
            poses: robots.iter().map(|r| vec![(0.0, r.pose)]).collect(),
            last_contact_s: vec![f64::NEG_INFINITY; robots.len()],
            robots,
            observers,
            director: Director::new(
                spec.plans.clone(),
                spec.repeat,
                Rng::stream(seed, "kicks", 0),
            ),
            observe: true,
            truth: vec![t0],
            next_truth: 1,
            events: Vec::new(),
            pending: Vec::new(),
            stats: SimStats::default(),
            phantom: None,
        }
    }

    /// Runs the ball's physics alone to the end (observers never touch it, see `rng`), and
    /// puts robot `i`'s phantom where the ball never comes: the grid point farthest from
    /// the whole true path.
    fn place_phantom(&mut self, i: usize) {
        let mut dry = self.clone();
        dry.observe = false;
        dry.advance_to(self.duration_s);
        let path: Vec<V2> = dry.truth.iter().step_by(5).map(|s| s.position_m).collect();
        let [lx, ly] = self.walls.limit;
        let (mx, my) = (
            (lx - PHANTOM_MARGIN_M).max(0.0),
            (ly - PHANTOM_MARGIN_M).max(0.0),
        );
        let mut best = ([0.0, 0.0], f64::NEG_INFINITY);
        let n = 40;
        for a in 0..=n {
            for b in 0..=n {
                let p = [
                    -mx + 2.0 * mx * a as f64 / n as f64,
                    -my + 2.0 * my * b as f64 / n as f64,
                ];
                let clearance = path
                    .iter()
                    .map(|q| dist(*q, p))
                    .fold(f64::INFINITY, f64::min);
                if clearance > best.1 {
                    best = (p, clearance);
                }
            }
        }
        let Some(robot) = self.robots.get(i) else {
            return;
        };
        self.phantom = Some((robot.id.clone(), best.0));
        for o in self.observers.iter_mut().filter(|o| o.index == i) {
            o.phantom_spot = Some(best.0);
        }
    }

    pub fn scenario(&self) -> &str {
        &self.scenario
    }

    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The scenario's length (a live caller may step beyond it; the world goes on).
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// Time of the world's state: the last grid point stepped to.
    pub fn time_s(&self) -> f64 {
        self.step_index as f64 * self.cfg.physics_dt_s
    }

    pub fn params(&self) -> &TrueParams {
        &self.params
    }

    /// The ball's current true state.
    pub fn ball_now(&self) -> TruthSample {
        TruthSample {
            t_s: self.time_s(),
            position_m: self.ball.pos,
            velocity_mps: self.ball.vel,
            phase: self.ball.phase,
        }
    }

    /// Current true robot poses, by id.
    pub fn robot_poses(&self) -> Vec<(String, Pose2)> {
        self.robots.iter().map(|r| (r.id.clone(), r.pose)).collect()
    }

    /// Truth samples recorded so far.
    pub fn truth(&self) -> &[TruthSample] {
        &self.truth
    }

    /// Ball events so far.
    pub fn events(&self) -> &[BallEvent] {
        &self.events
    }

    /// Steps the world until it has covered `t_s` and returns the observations captured up
    /// to `t_s` not returned before, in capture order, each stamped with its arrival.
    pub fn advance_to(&mut self, t_s: f64) -> Vec<Delivery> {
        while self.time_s() < t_s - 1e-12 {
            self.step_once();
        }
        let (ready, later): (Vec<_>, Vec<_>) = self
            .pending
            .drain(..)
            .partition(|(tc, _)| *tc <= t_s + 1e-12);
        self.pending = later;
        ready.into_iter().map(|(_, d)| d).collect()
    }

    fn step_once(&mut self) {
        let dt = self.cfg.physics_dt_s;
        let t0 = self.time_s();
        let positions: Vec<V2> = self.robots.iter().map(Robot::pos).collect();
        let orders = self.director.update(&View {
            t_s: t0,
            dt_s: dt,
            ball: &self.ball,
            robots: &positions,
            params: &self.params,
            walls: &self.walls,
            robot_limit: self.robot_limit,
        });
        if let Some(kick) = orders.kick {
            let (robot_id, distance) = match kick.robot.and_then(|i| self.robots.get(i)) {
                Some(r) => (r.id.clone(), dist(r.pos(), self.ball.pos)),
                None => ("script".to_string(), 0.0),
            };
            self.ball.kick(kick.velocity);
            self.events.push(BallEvent::Kick {
                t_s: t0,
                robot_id,
                velocity_mps: kick.velocity,
                kicker_distance_m: distance,
            });
        }
        let prev_ball = self.ball;
        let prev_poses: Vec<Pose2> = self.robots.iter().map(|r| r.pose).collect();
        let lanes: Vec<(V2, V2)> = ball_path(self.ball.pos, self.ball.vel)
            .into_iter()
            .chain(orders.lane)
            .collect();
        for (i, r) in self.robots.iter_mut().enumerate() {
            let chase = orders.chase.filter(|(k, _)| *k == i).map(|(_, d)| d);
            r.update(t0, dt, self.ball.pos, &lanes, chase, self.robot_limit);
        }
        separate(&mut self.robots, self.robot_limit);
        for (r, p) in self.robots.iter_mut().zip(&prev_poses) {
            r.vel = scale(sub(r.pos(), [p.x_m, p.y_m]), 1.0 / dt);
        }
        let mut phys = Vec::new();
        step(
            &mut self.ball,
            dt,
            &self.params,
            &self.walls,
            &mut self.physics_rng,
            &mut phys,
        );
        self.step_index += 1;
        let t1 = self.time_s();
        self.record_physics(t0, &phys);
        self.resolve_contacts(t1);
        self.record_truth(t0, t1, &prev_ball, &prev_poses);
        if self.observe {
            self.capture(t0, t1, &prev_ball, &prev_poses);
        }
    }

    fn record_physics(&mut self, t0: f64, phys: &[PhysEvent]) {
        for e in phys {
            self.events.push(match *e {
                PhysEvent::Bounce {
                    dt_s,
                    pos,
                    wall,
                    restitution,
                    ..
                } => BallEvent::WallBounce {
                    t_s: t0 + dt_s,
                    position_m: pos,
                    wall,
                    restitution,
                },
                PhysEvent::Stopped { dt_s, pos } => BallEvent::Stopped {
                    t_s: t0 + dt_s,
                    position_m: pos,
                },
            });
        }
    }

    fn resolve_contacts(&mut self, t1: f64) {
        let bodies: Vec<Body> = self
            .robots
            .iter()
            .map(|r| Body {
                pos: r.pos(),
                vel: r.vel,
                radius_m: ROBOT_RADIUS_M,
            })
            .collect();
        for (i, struck) in robot_contacts(
            &mut self.ball,
            self.cfg.pitch.ball_radius_m,
            &bodies,
            &self.walls,
        ) {
            if struck && t1 - self.last_contact_s[i] > CONTACT_DEBOUNCE_S {
                self.events.push(BallEvent::RobotContact {
                    t_s: t1,
                    robot_id: self.robots[i].id.clone(),
                });
            }
            self.last_contact_s[i] = t1;
        }
    }

    /// The ball and robots at `t` in (t0, t1], interpolated between the grid states.
    fn interpolate(
        &self,
        t: f64,
        t0: f64,
        prev_ball: &Ball,
        prev_poses: &[Pose2],
    ) -> (TruthSample, Vec<Pose2>) {
        let f = ((t - t0) / self.cfg.physics_dt_s).clamp(0.0, 1.0);
        let phase = if f < 0.5 {
            prev_ball.phase
        } else {
            self.ball.phase
        };
        let velocity_mps = if phase == BallPhase::Rest {
            [0.0, 0.0]
        } else {
            lerp(prev_ball.vel, self.ball.vel, f)
        };
        let ball = TruthSample {
            t_s: t,
            position_m: lerp(prev_ball.pos, self.ball.pos, f),
            velocity_mps,
            phase,
        };
        let poses = prev_poses
            .iter()
            .zip(&self.robots)
            .map(|(a, r)| {
                let p = lerp([a.x_m, a.y_m], r.pos(), f);
                Pose2 {
                    x_m: p[0],
                    y_m: p[1],
                    theta_rad: lerp_angle(a.theta_rad, r.pose.theta_rad, f),
                }
            })
            .collect();
        (ball, poses)
    }

    fn record_truth(&mut self, t0: f64, t1: f64, prev_ball: &Ball, prev_poses: &[Pose2]) {
        loop {
            let t = self.next_truth as f64 / self.cfg.truth_rate_hz;
            if t > t1 + 1e-9 {
                break;
            }
            let (ball, poses) = self.interpolate(t, t0, prev_ball, prev_poses);
            self.truth.push(ball);
            for (track, pose) in self.poses.iter_mut().zip(poses) {
                track.push((t, pose));
            }
            self.next_truth += 1;
        }
    }

    fn capture(&mut self, t0: f64, t1: f64, prev_ball: &Ball, prev_poses: &[Pose2]) {
        for k in 0..self.observers.len() {
            while self.observers[k].next_capture_s() <= t1 {
                let t = self.observers[k].next_capture_s();
                let (ball, poses) = self.interpolate(t, t0, prev_ball, prev_poses);
                let scene = Scene {
                    ball: ball.position_m,
                    poses: &poses,
                    ball_radius_m: self.cfg.pitch.ball_radius_m,
                    start: self.cfg.start,
                };
                let got = self.observers[k].capture(&scene, &mut self.stats);
                self.pending.extend(got);
            }
        }
    }

    /// The run so far as a `SimRun`, cut at the scenario's duration. `deliveries` are the
    /// observations handed out by `advance_to` (sorted here by arrival).
    pub fn into_run(self, mut deliveries: Vec<Delivery>) -> SimRun {
        deliveries.sort_by(|a, b| {
            (a.arrival, a.obs.stamp)
                .cmp(&(b.arrival, b.obs.stamp))
                .then_with(|| a.obs.robot_id.cmp(&b.obs.robot_id))
        });
        let end = self.duration_s + 1e-9;
        let mut events: Vec<BallEvent> =
            self.events.into_iter().filter(|e| e.t_s() <= end).collect();
        events.sort_by(|a, b| a.t_s().total_cmp(&b.t_s()));
        let robots = self
            .robots
            .iter()
            .zip(self.poses)
            .enumerate()
            .map(|(i, (r, mut poses))| {
                poses.retain(|(t, _)| *t <= end);
                let o = self.observers.iter().find(|o| o.index == i);
                RobotTrack {
                    id: r.id.clone(),
                    observer: r.observer,
                    poses,
                    cov_scale: o.map_or(1.0, |o| o.cov_scale),
                    clock_offset_s: o.map_or(0.0, |o| o.clock_offset_s),
                    frames: o.map_or(0, |o| o.frames),
                    stalls: o.map_or_else(Vec::new, |o| {
                        o.stalls.iter().filter(|s| s[0] <= end).copied().collect()
                    }),
                }
            })
            .collect();
        let mut truth = self.truth;
        truth.retain(|s| s.t_s <= end);
        SimRun {
            scenario: self.scenario,
            seed: self.seed,
            start: self.cfg.start,
            duration_s: self.duration_s,
            pitch: self.cfg.pitch,
            truth,
            robots,
            deliveries,
            events,
            params: self.params,
            stats: self.stats,
            phantom: self.phantom,
        }
    }
}

/// Observers for the observing robots: latency links, clock offsets, and which of them
/// misreport their covariance (a shuffled `floor(fraction · n)` of them, alternately
/// under- (×¼) and over-reporting (×4)).
fn make_observers(
    robots: &[Robot],
    seed: u64,
    cfg: &SimConfig,
    spec: &ScenarioSpec,
) -> Vec<Observer> {
    let observing: Vec<usize> = (0..robots.len()).filter(|&i| robots[i].observer).collect();
    let n_mis = ((cfg.misreport_fraction * observing.len() as f64) + 1e-9).floor() as usize;
    let mut order = observing.clone();
    Rng::stream(seed, "misreport", 0).shuffle(&mut order);
    observing
        .iter()
        .map(|&i| {
            let rank = order.iter().position(|&j| j == i).unwrap_or(usize::MAX);
            let cov_scale = match rank {
                r if r < n_mis && r % 2 == 0 => 0.25,
                r if r < n_mis => 4.0,
                _ => 1.0,
            };
            let mut clock = Rng::stream(seed, "clock", i as u64);
            let m = cfg.clock_offset_max_s;
            let offset = if m > 0.0 { clock.range(-m, m) } else { 0.0 };
            Observer::new(
                i,
                robots[i].id.clone(),
                seed,
                spec.latency,
                offset,
                cov_scale,
            )
            .with_frame_rate(spec.frame_rate_hz)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slicing_time_differently_gives_the_same_world() {
        let cfg = SimConfig::default();
        let mut a = World::new("team-rally", 3, &cfg).unwrap_or_else(|e| panic!("{e}"));
        let mut b = a.clone();
        let mut da = a.advance_to(6.0);
        let mut db = Vec::new();
        let mut t: f64 = 0.0;
        while t < 6.0 {
            t = (t + 0.0137).min(6.0);
            let got = b.advance_to(t);
            assert!(
                got.iter()
                    .all(|d| d.obs.stamp.secs_since(cfg.start) <= t + 1e-6)
            );
            db.extend(got);
        }
        assert_eq!(a.time_s(), b.time_s());
        assert_eq!(a.ball_now(), b.ball_now());
        let key = |d: &Delivery| (d.obs.robot_id.clone(), d.obs.seq);
        da.sort_by_key(key);
        db.sort_by_key(key);
        assert_eq!(da, db);
        assert_eq!(a.events(), b.events());
    }

    #[test]
    fn unknown_scenario_and_bad_config_are_errors() {
        let err = World::new("nope", 0, &SimConfig::default()).err();
        assert!(matches!(err, Some(SimError::UnknownScenario { .. })));
        let cfg = SimConfig {
            physics_dt_s: 0.0,
            ..SimConfig::default()
        };
        assert!(matches!(
            World::new("match", 0, &cfg).err(),
            Some(SimError::InvalidConfig(_))
        ));
    }

    #[test]
    fn misreporting_observers_alternate_under_and_over() {
        let cfg = SimConfig {
            misreport_fraction: 0.5,
            clock_offset_max_s: 0.05,
            ..SimConfig::default()
        };
        let w = World::new("team-rally", 1, &cfg).unwrap_or_else(|e| panic!("{e}"));
        let mut scales: Vec<f64> = w.observers.iter().map(|o| o.cov_scale).collect();
        scales.sort_by(f64::total_cmp);
        assert_eq!(scales, vec![0.25, 1.0, 1.0, 4.0]);
        assert!(
            w.observers
                .iter()
                .all(|o| o.clock_offset_s.abs() <= 0.05 && o.clock_offset_s != 0.0)
        );
        let w =
            World::new("team-rally", 1, &SimConfig::default()).unwrap_or_else(|e| panic!("{e}"));
        let n_mis = w.observers.iter().filter(|o| o.cov_scale != 1.0).count();
        assert_eq!(n_mis, 1);
    }
}

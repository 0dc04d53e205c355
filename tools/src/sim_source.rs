//! The `sim` source of `sim_agent`: a simulated match rendered through one robot's two
//! cameras, as a [`FrameSource`] of the agent's runtime.
//!
//! The agent learns nothing from the simulator but the images and the robot's own sensor
//! readings (a pose with a wandering error, head joints with encoder error): the lens is
//! the simulator's, known to the agent only through its calibration. The renderer's truth
//! of each frame goes into a queue beside the frames ([`SimSource::truths`]) for scoring
//! outside the agent.

use anyhow::{Context, Result};
use proto::{Camera, Stamp};
use robot_agent::FrameSource;
use robot_agent::{RobotState, StoredFrame};
use sim::BallTruth;
use sim::CameraRig;
use sim::LensModel;
use sim::{CameraWorld, CameraWorldConfig, patterned_ball};
use sim::{SimConfig, SimRun};
use std::collections::VecDeque;
use std::sync::{Arc, Mutex};
use vision::RgbImage;

#[derive(Debug, Clone, clap::Args)]
pub struct SimArgs {
    /// The match (the same flags as `demo`, `sim_robots` and `simulate`); its start
    /// defaults to now.
    #[command(flatten)]
    pub game: crate::sim_args::MatchArgs,
    /// The ball has white patches.
    #[arg(long)]
    pub patterned_ball: bool,
    /// Camera frames per second (both cameras).
    #[arg(long, default_value_t = 15.0)]
    pub camera_hz: f64,
    /// After the match, play the next seed from where it ended, and so on (processes that
    /// share the start and seed keep playing the same matches).
    #[arg(long)]
    pub repeat: bool,
}

#[derive(Debug)]
pub struct SimSource {
    robot_id: String,
    args: SimArgs,
    run: SimRun,
    rig: CameraRig,
    cfg: CameraWorldConfig,
    seed: u64,
    times: VecDeque<f64>,
    frame_index: u64,
    pending: VecDeque<StoredFrame>,
    truths: Truths,
}

/// The renderer's truth of each frame handed out, in order: (stamp, camera, truth).
pub type Truths = Arc<Mutex<VecDeque<(Stamp, Camera, Option<BallTruth>)>>>;

impl SimSource {
    pub fn new(robot_id: &str, args: &SimArgs, now: Stamp) -> Result<Self> {
        let start = args.game.start_or(now);
        let run = simulate(robot_id, args, args.game.seed, start)?;
        let mut cam_cfg = CameraWorldConfig {
            frame_rate_hz: args.camera_hz.clamp(0.5, 60.0),
            ..CameraWorldConfig::default()
        };
        if args.patterned_ball {
            cam_cfg.ball_look = patterned_ball();
        }
        let rig = CameraRig::new(LensModel::miro());
        let times = CameraWorld::new(&run, &rig, cam_cfg, args.game.seed)
            .frame_times()
            .collect();
        Ok(SimSource {
            robot_id: robot_id.to_string(),
            args: args.clone(),
            run,
            rig,
            cfg: cam_cfg,
            seed: args.game.seed,
            times,
            frame_index: 0,
            pending: VecDeque::new(),
            truths: Truths::default(),
        })
    }

    /// The queue the truth of every frame goes into as the frame is rendered.
    pub fn truths(&self) -> Truths {
        self.truths.clone()
    }

    /// Moves on to the next seed's match, starting where this one ended.
    fn next_match(&mut self) -> Result<()> {
        let start = self.run.stamp_of(self.run.duration_s);
        self.seed += 1;
        self.run = simulate(&self.robot_id, &self.args, self.seed, start)?;
        let world = CameraWorld::new(&self.run, &self.rig, self.cfg, self.seed);
        // The first frame of the new match would repeat the last one of the old.
        self.times = world.frame_times().skip(1).collect();
        tracing::info!("{}: next match, seed {}", self.robot_id, self.seed);
        Ok(())
    }
}

fn simulate(robot_id: &str, args: &SimArgs, seed: u64, start: Stamp) -> Result<SimRun> {
    let cfg = SimConfig {
        start,
        duration_s: args.game.duration_s,
        team_size: args.game.team_size,
        ..SimConfig::default()
    };
    let run = sim::run_scenario(&args.game.scenario, seed, &cfg)
        .with_context(|| format!("simulating {}", args.game.scenario))?;
    anyhow::ensure!(
        run.robot(robot_id).is_some(),
        "scenario {} has no robot {robot_id:?} (it has {})",
        args.game.scenario,
        run.robots
            .iter()
            .map(|r| r.id.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(run)
}

impl FrameSource for SimSource {
    fn next_frame(&mut self) -> Result<Option<StoredFrame>> {
        if let Some(c) = self.pending.pop_front() {
            return Ok(Some(c));
        }
        if self.times.is_empty() && self.args.repeat {
            self.next_match()?;
        }
        let Some(t_s) = self.times.pop_front() else {
            return Ok(None);
        };
        let world = CameraWorld::new(&self.run, &self.rig, self.cfg, self.seed);
        let capture = world.capture(&self.robot_id, t_s, self.frame_index);
        self.frame_index += 1;
        let stamp = self.run.stamp_of(t_s);
        let r = capture.reading;
        let state = RobotState {
            state_stamp: Some(stamp),
            pose: r.pose,
            pose_covariance: r.pose_covariance,
            head: r.head,
        };
        for ((frame, truth), camera) in capture
            .frames
            .into_iter()
            .zip([Camera::Left, Camera::Right])
        {
            let image = RgbImage::new(frame.width, frame.height, frame.rgb)?;
            if let Ok(mut q) = self.truths.lock() {
                q.push_back((stamp, camera, truth));
            }
            self.pending.push_back(StoredFrame {
                stamp,
                camera,
                image,
                state,
            });
        }
        Ok(self.pending.pop_front())
    }

    fn live(&self) -> bool {
        true
    }
}

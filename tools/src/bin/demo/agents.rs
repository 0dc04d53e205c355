//! The demo's robots as `sim_agent` processes: each renders its own two cameras of the
//! simulated match and runs the robot agent's own loop on them (finds the ball in the
//! frames, publishes over Zenoh), exactly as on a robot. Every process simulates the same
//! match (same scenario, seed and start).

use anyhow::{Context, Result};
use proto::Stamp;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};

/// The `sim_agent` binary next to this one (cargo builds both into the same folder).
pub fn agent_binary() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let bin = exe.with_file_name(format!("sim_agent{}", std::env::consts::EXE_SUFFIX));
    bin.is_file().then_some(bin)
}

/// What every agent of the demo shares.
#[derive(Debug, Clone)]
pub struct AgentsConfig {
    pub binary: PathBuf,
    pub scenario: String,
    pub seed: u64,
    pub team_size: usize,
    pub match_s: f64,
    pub start: Stamp,
    pub camera_hz: f64,
    /// Camera views per second per camera (`--view-hz`; 0: none).
    pub view_hz: f64,
    pub endpoint: String,
    pub prefix: String,
}

/// Running agent processes; dropping them stops them.
#[derive(Debug)]
pub struct Agents {
    children: Vec<(String, Child)>,
}

impl Agents {
    /// Starts one agent per robot id.
    pub fn spawn(cfg: &AgentsConfig, ids: &[String]) -> Result<Self> {
        let mut children = Vec::new();
        for id in ids {
            let child = Command::new(&cfg.binary)
                .args(["--robot-id", id, "--repeat"])
                .args(["--scenario", &cfg.scenario])
                .args(["--seed", &cfg.seed.to_string()])
                .args(["--team-size", &cfg.team_size.to_string()])
                .args(["--duration-s", &cfg.match_s.to_string()])
                .args(["--start-ns", &cfg.start.0.to_string()])
                .args(["--camera-hz", &cfg.camera_hz.to_string()])
                .args(["--view-hz", &cfg.view_hz.to_string()])
                .args(["--connect", &cfg.endpoint, "--prefix", &cfg.prefix])
                // Agents stop by themselves should the demo die without stopping them.
                .args(["--parent-pid", &std::process::id().to_string()])
                .env("RUST_LOG", "warn,zenoh=error")
                .stdin(Stdio::null())
                .stdout(Stdio::null())
                .spawn()
                .with_context(|| format!("starting {}", cfg.binary.display()))?;
            children.push((id.clone(), child));
        }
        Ok(Agents { children })
    }

    /// Agents that have exited, with their status.
    pub fn exited(&mut self) -> Vec<(String, std::process::ExitStatus)> {
        self.children
            .iter_mut()
            .filter_map(|(id, c)| c.try_wait().ok().flatten().map(|s| (id.clone(), s)))
            .collect()
    }

    /// Stops every agent.
    pub fn stop(&mut self) {
        for (_, c) in &mut self.children {
            let _ = c.kill();
            let _ = c.wait();
        }
        self.children.clear();
    }
}

impl Drop for Agents {
    fn drop(&mut self) {
        self.stop();
    }
}

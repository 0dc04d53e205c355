//! Labelled candidate patches from the simulator, for training the ball classifier the way
//! the seed collected its data: the candidates the detector's first stages really propose,
//! each labelled by the renderer's ground truth.
//!
//! Frames come from simulated matches through every robot's cameras, and candidates are
//! proposed in their local views through the agent's calibration of the simulated camera,
//! exactly as the running agent sees them. Candidates are mined
//! with the agent's two mining windows ([`lab::training_miners`]): the
//! ball's own (wide) window with the two-colour mask of a patterned ball, which proposes
//! the ball, plain or patterned, and orange-ish look-alikes (wall markings, alone or joined
//! with the white wall behind them, partly hidden balls), and a window for white and grey
//! things, which proposes robot heads and bodies, the walls and the patterned ball's white
//! patches: the round look-alikes the shape filter must learn to refuse.

use anyhow::Result;
use lab::training_miners as miners;
use robot_agent::CameraModel;
use sim::BallTruth;
use sim::CameraRig;
use sim::LensModel;
use sim::{CameraWorld, CameraWorldConfig, patterned_ball};
use sim::{SimConfig, run_scenario};
use vision::NoClock;
use vision::RgbImage;
use vision::settings::PatchConfig;
use vision::stages::patch::Patch;
use vision::stages::patch::extract;

/// How a candidate relates to the true ball.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Label {
    Ball,
    NotBall,
    /// Overlaps the ball without matching it: left out of training.
    Unclear,
}

/// Labels a candidate circle against the renderer's truth.
pub fn label(center_px: [f64; 2], radius_px: f64, truth: Option<&BallTruth>) -> Label {
    let Some(t) = truth.filter(|t| t.in_frame) else {
        return Label::NotBall;
    };
    let Some(c) = t.center_px else {
        return Label::NotBall;
    };
    let d = (center_px[0] - c[0]).hypot(center_px[1] - c[1]);
    if d <= (0.3 * t.radius_px).max(1.5)
        && (radius_px - t.radius_px).abs() <= 0.3 * t.radius_px.max(4.0)
        && t.visible_fraction >= 0.6
    {
        Label::Ball
    } else if d > t.radius_px + radius_px {
        Label::NotBall
    } else {
        Label::Unclear
    }
}

/// Positive and negative patches from `matches` simulated matches of `seconds` each.
pub fn mine(
    model: &CameraModel,
    matches: u64,
    seconds: f64,
    seed: u64,
    progress: &mut dyn FnMut(&str),
) -> Result<(Vec<Patch>, Vec<Patch>)> {
    let rig = CameraRig::new(LensModel::miro());
    let detectors = miners()?;
    let patch_cfg = PatchConfig::default();
    let (mut pos, mut neg) = (Vec::new(), Vec::new());
    for m in 0..matches {
        let match_seed = seed.wrapping_mul(1000).wrapping_add(m);
        let cfg = SimConfig {
            duration_s: Some(seconds),
            ..SimConfig::default()
        };
        let run = run_scenario("match", match_seed, &cfg)?;
        let mut cam = CameraWorldConfig {
            frame_rate_hz: 2.0,
            ..CameraWorldConfig::default()
        };
        if m % 2 == 1 {
            cam.ball_look = patterned_ball();
        }
        let world = CameraWorld::new(&run, &rig, cam, match_seed);
        let ids: Vec<String> = run.robots.iter().map(|r| r.id.clone()).collect();
        for (k, t) in world.frame_times().enumerate() {
            for id in &ids {
                let capture = world.capture(id, t, k as u64);
                for (frame, truth) in &capture.frames {
                    let image = RgbImage::new(frame.width, frame.height, frame.rgb.clone())?;
                    for detector in &detectors {
                        let proposals = detector.propose(&image, Some(model), &mut NoClock)?;
                        for p in &proposals.items {
                            let view = proposals.image(p, &image);
                            let Ok(patch) =
                                extract(view, p.local.center_px, p.local.radius_px, &patch_cfg)
                            else {
                                continue;
                            };
                            match label(p.frame.center_px, p.frame.radius_px, truth.as_ref()) {
                                Label::Ball => pos.push(patch),
                                Label::NotBall => neg.push(patch),
                                Label::Unclear => {}
                            }
                        }
                    }
                }
            }
        }
        progress(&format!(
            "match {}/{matches}: {} ball and {} other candidates so far",
            m + 1,
            pos.len(),
            neg.len()
        ));
    }
    Ok((pos, neg))
}

//! `sim_frames`: frames rendered by the simulator's MiRo cameras from simulated matches,
//! with the renderer's ball boxes as YOLO labels (class 0 `ball`, `obj.names` beside them),
//! as training or test data for `ball-lab train` and `evaluate`. Frames where the ball
//! is only partly seen (cut by the image's edge or hidden by more than a tenth) are left
//! out, as their label would be unfair; at most one frame in `--empty-every` without a
//! ball is kept.

use anyhow::{Context, Result};
use clap::Parser;
use lab::labels::BallBox;
use sim::{CameraRig, CameraWorld, CameraWorldConfig, LensModel, SimConfig, run_scenario};
use std::path::PathBuf;
use tools::progress::Progress;
use vision::RgbImage;

#[derive(Debug, Parser)]
#[command(about = "Write rendered MiRo camera frames of simulated matches with YOLO ball labels")]
struct Args {
    /// Simulated matches to render (seeds `--seed`, `--seed + 1`, ...).
    #[arg(long, default_value_t = 4)]
    matches: u64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Seconds of each match.
    #[arg(long, default_value_t = 20.0)]
    seconds: f64,
    /// Frames per second rendered from each robot's two cameras.
    #[arg(long, default_value_t = 1.0)]
    rate_hz: f64,
    /// Keep one frame without a ball in this many.
    #[arg(long, default_value_t = 4)]
    empty_every: usize,
    /// The folder to write (`m{seed}/` subfolders of PNG frames and YOLO `.txt` labels).
    #[arg(long)]
    out: PathBuf,
}

fn main() {
    if let Err(e) = run(Args::parse()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run(args: Args) -> Result<()> {
    anyhow::ensure!(
        args.rate_hz > 0.0 && args.seconds > 0.0,
        "--rate-hz and --seconds must be positive"
    );
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    std::fs::write(args.out.join("obj.names"), "ball\n")?;
    let progress = Progress::new(args.matches, "matches");
    let (mut with_ball, mut without, mut empty_seen) = (0usize, 0usize, 0usize);
    for m in 0..args.matches {
        let seed = args.seed + m;
        let dir = args.out.join(format!("m{seed}"));
        std::fs::create_dir_all(&dir)?;
        let cfg = SimConfig {
            duration_s: Some(args.seconds),
            ..SimConfig::default()
        };
        let run = run_scenario("match", seed, &cfg)?;
        let rig = CameraRig::new(LensModel::miro());
        let cam = CameraWorldConfig {
            frame_rate_hz: args.rate_hz,
            ..CameraWorldConfig::default()
        };
        let world = CameraWorld::new(&run, &rig, cam, seed);
        let ids: Vec<String> = run.robots.iter().map(|r| r.id.clone()).collect();
        for (k, t) in world.frame_times().enumerate() {
            for id in &ids {
                let capture = world.capture(id, t, k as u64);
                for (side, (frame, truth)) in capture.frames.iter().enumerate() {
                    let ball = truth
                        .as_ref()
                        .and_then(|t| t.full_view_box_px(frame.width, frame.height))
                        .map(|[x0, y0, x1, y1]| BallBox {
                            x_min_px: x0,
                            y_min_px: y0,
                            x_max_px: x1,
                            y_max_px: y1,
                        });
                    let partly = truth.as_ref().is_some_and(|t| t.in_frame) && ball.is_none();
                    if partly {
                        continue;
                    }
                    if ball.is_none() {
                        empty_seen += 1;
                        if empty_seen % args.empty_every.max(1) != 0 {
                            continue;
                        }
                    }
                    let name = format!("{id}-{k:04}-{side}");
                    let image = RgbImage::new(frame.width, frame.height, frame.rgb.clone())?;
                    std::fs::write(
                        dir.join(format!("{name}.png")),
                        robot_agent::encode_png(&image)?,
                    )?;
                    let label: String = ball
                        .iter()
                        .map(|b| {
                            lab::labels::yolo::yolo_line(0, b, frame.width, frame.height) + "\n"
                        })
                        .collect();
                    std::fs::write(dir.join(format!("{name}.txt")), label)?;
                    if ball.is_some() {
                        with_ball += 1;
                    } else {
                        without += 1;
                    }
                }
            }
        }
        progress.inc(format!("match {seed}: {with_ball} frames with a ball"));
    }
    progress.finish();
    println!(
        "wrote {} frames with a ball and {without} without to {}",
        with_ball,
        args.out.display()
    );
    Ok(())
}

//! `sim_calibrate`: a camera model fitted to chessboard views rendered through the
//! simulator's MiRo camera (the images a person would take of a printed board in front of
//! a simulated MiRo), written as `ball-lab calibrate` writes one from photographs.
//! The shipped calibration of the simulated camera is
//! `sim_calibrate --fisheye --fisheye-terms 2 --out robot-agent/data/sim-calibration.toml`.
//!
//! Flags: `--views N` (default 24), `--seed N` (default 1), `--save-images DIR`, and those
//! of `ball-lab calibrate`: `--board COLSxROWS` (default 9x6, the simulator's board),
//! `--square M` (default 0.025), `--fisheye`, `--fisheye-terms N` (default 4), `--out FILE`.

use anyhow::{Context, Result, bail};
use clap::Parser;
use lab::cli::calibrate::{FitArgs, fit_and_write, parse_board};
use std::path::{Path, PathBuf};
use vision::GrayImage;
use vision::RgbImage;

#[derive(Debug, Parser)]
#[command(
    name = "sim_calibrate",
    about = "Calibrates the simulated MiRo camera from rendered chessboard views"
)]
struct Args {
    /// Views rendered.
    #[arg(long, default_value_t = 24)]
    views: usize,
    /// Seed of the rendered views' poses and noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Also write the rendered views as PNGs to this folder.
    #[arg(long)]
    save_images: Option<PathBuf>,
    #[command(flatten)]
    fit: FitArgs,
}

/// Chessboard views rendered through the simulator's camera.
fn sim_images(views: usize, seed: u64, save: Option<&Path>) -> Result<Vec<(String, GrayImage)>> {
    let lens = sim::LensModel::miro();
    let board = sim::Chessboard::default();
    if let Some(dir) = save {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let mut out = Vec::new();
    for (k, pose) in sim::calibration_views(&lens, views, seed)
        .iter()
        .enumerate()
    {
        let (frame, _) =
            sim::render_chessboard(&lens, &board, pose, 2.0, seed.wrapping_add(k as u64));
        let rgb = RgbImage::new(frame.width, frame.height, frame.rgb)?;
        let name = format!("board-{k:02}.png");
        if let Some(dir) = save {
            std::fs::write(dir.join(&name), robot_agent::encode_png(&rgb)?)?;
        }
        out.push((name, GrayImage::from_rgb(&rgb)));
    }
    Ok(out)
}

fn main() -> Result<()> {
    let args = Args::parse();
    let board = parse_board(&args.fit.board, args.fit.square)?;
    let sim_board = sim::Chessboard::default();
    if (board.cols, board.rows) != (sim_board.inner_cols, sim_board.inner_rows)
        || (board.square_m - sim_board.square_m).abs() > 1e-12
    {
        bail!(
            "the simulator renders a {}x{} board with {} m squares",
            sim_board.inner_cols,
            sim_board.inner_rows,
            sim_board.square_m
        );
    }
    let images = sim_images(args.views, args.seed, args.save_images.as_deref())?;
    fit_and_write(&images, &board, &args.fit)
}

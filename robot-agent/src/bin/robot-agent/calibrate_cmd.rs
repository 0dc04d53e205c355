//! `robot-agent calibrate`: a camera model from chessboard images, as a TOML file.
//!
//! `--images DIR` takes every PNG and JPEG in the folder; `--from-sim` renders chessboard
//! views through the simulator's camera first (the same images a person would take of a
//! printed board in front of a simulated MiRo) and calibrates from those.

use anyhow::{Context, Result, bail};
use robot_agent::calibrate::{Board, Calibration, LensModel, calibrate_with, detect_views};
use robot_agent::gray::GrayImage;
use robot_agent::image::RgbImage;
use std::path::{Path, PathBuf};

#[derive(Debug, clap::Args)]
pub struct CalibrateArgs {
    /// Folder of chessboard photographs (PNG or JPEG, all the same size).
    #[arg(long, required_unless_present = "from_sim")]
    pub images: Option<PathBuf>,
    /// Render chessboard views through the simulator's MiRo camera instead.
    #[arg(long, conflicts_with = "images")]
    pub from_sim: bool,
    /// Views rendered with `--from-sim`.
    #[arg(long, default_value_t = 24)]
    pub views: usize,
    /// Seed of the rendered views' poses and noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Also write the rendered views as PNGs to this folder.
    #[arg(long)]
    pub save_images: Option<PathBuf>,
    /// Inner corners per row × per column, e.g. 9x6.
    #[arg(long, default_value = "9x6")]
    pub board: String,
    /// Side of a square, metres.
    #[arg(long, default_value_t = 0.025)]
    pub square: f64,
    /// Fit the Kannala–Brandt fisheye model instead of Brown–Conrady.
    #[arg(long)]
    pub fisheye: bool,
    /// Kannala–Brandt coefficients fitted (1 to 4; the rest are held at zero). Fewer
    /// extrapolate better into image corners that no board reached.
    #[arg(long, default_value_t = 4)]
    pub fisheye_terms: usize,
    /// Where to write the calibration (TOML).
    #[arg(long)]
    pub out: PathBuf,
}

fn parse_board(text: &str, square_m: f64) -> Result<Board> {
    let (c, r) = text
        .split_once(['x', 'X'])
        .with_context(|| format!("board {text:?} is not COLSxROWS, e.g. 9x6"))?;
    let cols: usize = c
        .trim()
        .parse()
        .with_context(|| format!("board {text:?}"))?;
    let rows: usize = r
        .trim()
        .parse()
        .with_context(|| format!("board {text:?}"))?;
    if cols < 2 || rows < 2 || !(square_m > 0.0 && square_m.is_finite()) {
        bail!("board {text:?} with {square_m} m squares is not a chessboard");
    }
    Ok(Board {
        cols,
        rows,
        square_m,
    })
}

/// The images of a folder, sorted by name.
fn folder_images(dir: &Path) -> Result<Vec<(String, GrayImage)>> {
    let paths = crate::frames_io::image_files(dir)?;
    let mut out = Vec::new();
    for p in paths {
        let name = p
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        match robot_agent::image_io::load_gray(&p) {
            Ok(image) => out.push((name, image)),
            Err(e) => eprintln!("skipping {name}: {e}"),
        }
    }
    Ok(out)
}

/// Chessboard views rendered through the simulator's camera.
pub fn sim_images(
    views: usize,
    seed: u64,
    save: Option<&Path>,
) -> Result<Vec<(String, GrayImage)>> {
    let lens = sim::lens::LensModel::miro();
    let board = sim::chessboard::Chessboard::default();
    if let Some(dir) = save {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let mut out = Vec::new();
    for (k, pose) in sim::chessboard::calibration_views(&lens, views, seed)
        .iter()
        .enumerate()
    {
        let (frame, _) = sim::chessboard::render_chessboard(
            &lens,
            &board,
            pose,
            2.0,
            seed.wrapping_add(k as u64),
        );
        let rgb = RgbImage::new(frame.width, frame.height, frame.rgb)?;
        let name = format!("board-{k:02}.png");
        if let Some(dir) = save {
            std::fs::write(dir.join(&name), robot_agent::image_io::encode_png(&rgb)?)?;
        }
        out.push((name, GrayImage::from_rgb(&rgb)));
    }
    Ok(out)
}

pub fn print_report(c: &Calibration) {
    println!("{:<28} {:>9}  used", "view", "rms px");
    for v in &c.per_view {
        let rms = v.rms_px.map_or("-".to_string(), |r| format!("{r:.3}"));
        let why = v.reason.as_deref().unwrap_or("");
        println!(
            "{:<28} {rms:>9}  {}  {why}",
            v.name,
            if v.used { "yes" } else { "no " }
        );
    }
    let i = &c.model.intrinsics;
    println!(
        "{} of {} views used, RMS reprojection error {:.3} px",
        c.views_used,
        c.per_view.len(),
        c.rms_px
    );
    println!(
        "fx {:.2} px, fy {:.2} px, cx {:.2} px, cy {:.2} px, {}×{}; distortion {:?}",
        i.fx_px, i.fy_px, i.cx_px, i.cy_px, i.width_px, i.height_px, c.model.distortion
    );
}

pub fn run(args: CalibrateArgs) -> Result<()> {
    let board = parse_board(&args.board, args.square)?;
    let images = match &args.images {
        Some(dir) => folder_images(dir)?,
        None => {
            let sim_board = sim::chessboard::Chessboard::default();
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
            sim_images(args.views, args.seed, args.save_images.as_deref())?
        }
    };
    let Some((_, first)) = images.first() else {
        bail!("no PNG or JPEG images to calibrate from");
    };
    let (w, h) = (first.width(), first.height());
    if let Some((name, _)) = images
        .iter()
        .find(|(_, i)| (i.width(), i.height()) != (w, h))
    {
        bail!(
            "{name} is not {w}×{h} like the first image; calibrate one camera's images at a time"
        );
    }
    eprintln!(
        "finding the {}x{} board in {} images…",
        board.cols,
        board.rows,
        images.len()
    );
    let views = detect_views(&images, &board);
    let lens = if args.fisheye {
        LensModel::KannalaBrandt
    } else {
        LensModel::BrownConrady
    };
    let calibration = calibrate_with(&views, &board, w, h, lens, args.fisheye_terms)?;
    print_report(&calibration);
    if let Some(parent) = args.out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)?;
    }
    std::fs::write(&args.out, calibration.to_toml_string()?)
        .with_context(|| format!("writing {}", args.out.display()))?;
    println!("wrote {}", args.out.display());
    Ok(())
}

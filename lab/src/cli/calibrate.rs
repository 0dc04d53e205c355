//! Calibrating a camera from chessboard images, shared by `ball-lab calibrate` (a folder
//! of photographs) and the tools' `sim_calibrate` (views rendered through the
//! simulator's camera): the board and lens flags, the fit, its report and the TOML file.

use crate::calibration::calibrate::{Board, LensModel, calibrate_with, detect_views};
use anyhow::{Context, Result, bail};
use robot_agent::Calibration;
use std::path::{Path, PathBuf};
use vision::image::gray::GrayImage;

/// The board, the lens model fitted and where the calibration goes.
#[derive(Debug, clap::Args)]
pub struct FitArgs {
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

/// The board of `--board` and `--square`.
pub fn parse_board(text: &str, square_m: f64) -> Result<Board> {
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
pub fn folder_images(dir: &Path) -> Result<Vec<(String, GrayImage)>> {
    let paths = robot_agent::image_files(dir)?;
    let mut out = Vec::new();
    for p in paths {
        let name = p
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        match robot_agent::load_gray(&p) {
            Ok(image) => out.push((name, image)),
            Err(e) => eprintln!("skipping {name}: {e}"),
        }
    }
    Ok(out)
}

/// The calibration's per-view errors, its RMS error and the fitted model.
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

/// Calibrates from `images` (all one camera's, the same size), prints the report and
/// writes the calibration to `--out`.
pub fn fit_and_write(images: &[(String, GrayImage)], board: &Board, fit: &FitArgs) -> Result<()> {
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
    let views = detect_views(images, board);
    let lens = if fit.fisheye {
        LensModel::KannalaBrandt
    } else {
        LensModel::BrownConrady
    };
    let calibration = calibrate_with(&views, board, w, h, lens, fit.fisheye_terms)?;
    print_report(&calibration);
    if let Some(parent) = fit.out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)?;
    }
    std::fs::write(&fit.out, calibration.to_toml_string()?)
        .with_context(|| format!("writing {}", fit.out.display()))?;
    println!("wrote {}", fit.out.display());
    Ok(())
}

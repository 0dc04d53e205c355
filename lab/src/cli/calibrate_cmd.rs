//! `ball-lab calibrate`: a camera model from a folder of chessboard photographs (every
//! PNG and JPEG in it), as a TOML file.

use crate::cli::calibrate::{FitArgs, fit_and_write, folder_images, parse_board};
use anyhow::Result;
use std::path::PathBuf;

#[derive(Debug, clap::Args)]
pub struct CalibrateArgs {
    /// Folder of chessboard photographs (PNG or JPEG, all the same size).
    #[arg(long)]
    pub images: PathBuf,
    #[command(flatten)]
    pub fit: FitArgs,
}

pub fn run(args: CalibrateArgs) -> Result<()> {
    let board = parse_board(&args.fit.board, args.fit.square)?;
    let images = folder_images(&args.images)?;
    fit_and_write(&images, &board, &args.fit)
}

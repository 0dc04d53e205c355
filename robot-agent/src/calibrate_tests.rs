#![allow(clippy::unwrap_used)]

use super::*;
use crate::calibration_fixtures::{photo, photo_names};

fn photo_views(board: &Board) -> Vec<View> {
    let images: Vec<(String, GrayImage)> = photo_names()
        .into_iter()
        .map(|n| (n.to_string(), photo(n)))
        .collect();
    detect_views(&images, board)
}

#[test]
fn calibrates_the_photographs() {
    let board = Board {
        cols: 9,
        rows: 6,
        square_m: 0.025,
    };
    let views = photo_views(&board);
    let c = calibrate(&views, &board, 640, 480, LensModel::BrownConrady).unwrap();
    eprintln!("{c:#?}");
    assert!(c.rms_px < 0.5);
}

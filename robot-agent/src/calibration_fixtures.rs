//! Test fixtures of the calibration tests: the chessboard photographs and synthetic
//! renders of a chessboard through a known camera.

#![allow(clippy::unwrap_used)]

use std::path::Path;

use crate::gray::GrayImage;

/// The names of the chessboard photographs in `tests/data/chessboard-photos`.
pub fn photo_names() -> Vec<&'static str> {
    vec![
        "left01.jpg",
        "left02.jpg",
        "left03.jpg",
        "left04.jpg",
        "left05.jpg",
        "left06.jpg",
        "left07.jpg",
        "left08.jpg",
        "left09.jpg",
        "left11.jpg",
        "left12.jpg",
        "left13.jpg",
        "left14.jpg",
    ]
}

/// One chessboard photograph.
pub fn photo(name: &str) -> GrayImage {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/chessboard-photos")
        .join(name);
    crate::image_io::load_gray(&path).unwrap()
}

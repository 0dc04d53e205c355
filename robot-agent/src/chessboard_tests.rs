#![allow(clippy::unwrap_used)]

use super::*;
use crate::calibration_fixtures::{photo, photo_names};

#[test]
fn finds_the_board_in_the_photographs() {
    let mut found = 0;
    for name in photo_names() {
        let image = photo(name);
        match find_chessboard(&image, 9, 6) {
            Ok(corners) => {
                found += 1;
                assert_eq!(corners.len(), 54);
                eprintln!("{name}: first {:?} last {:?}", corners[0], corners[53]);
            }
            Err(e) => eprintln!("{name}: {e}"),
        }
    }
    assert!(found >= 12, "found the board in {found} photos");
}

//! Tests of the connected components: a disc among other blobs, and 8-neighbour merging.

#![allow(clippy::unwrap_used)]

use super::*;

use crate::test_fixtures::{CENTRE, RADIUS, disc_mask};

#[test]
fn components_find_the_disc() {
    let mut m = disc_mask();
    // A speck and a smaller blob elsewhere.
    m.set(3, 3, true);
    for y in 100..106 {
        for x in 130..140 {
            m.set(x, y, true);
        }
    }
    let found = largest_components(&m, 5, 5);
    assert_eq!(found.len(), 2);
    let disc = found[0];
    assert_eq!(disc.area_px, disc_mask().count());
    assert!((disc.area_px as f64 - std::f64::consts::PI * RADIUS * RADIUS).abs() < 40.0);
    assert!((disc.centroid_px[0] - CENTRE[0]).abs() <= 0.5);
    assert!((disc.centroid_px[1] - CENTRE[1]).abs() <= 0.5);
    assert_eq!(
        disc.bbox,
        BoundingBox {
            x_min: 51,
            y_min: 36,
            x_max: 90,
            y_max: 75
        }
    );
    assert_eq!(found[1].area_px, 60);
    assert_eq!(found[1].centroid_px, [134.5, 102.5]);
    assert_eq!(largest_components(&m, 1, 1).len(), 1);
    assert_eq!(largest_components(&m, 1, 10).len(), 3);
    assert!(largest_components(&m, 10_000, 10).is_empty());
}

#[test]
fn components_join_diagonals_and_merge_labels() {
    // A diagonal line and a "U" whose arms get different provisional labels.
    let rows = ["1000100010", "0100100010", "0010100010", "0001011110"];
    let data = rows
        .iter()
        .flat_map(|r| r.bytes().map(|b| b - b'0'))
        .collect();
    let m = Mask::new(10, 4, data).unwrap();
    let found = largest_components(&m, 1, 10);
    let areas: Vec<usize> = found.iter().map(|c| c.area_px).collect();
    // The diagonal's last pixel (3, 3) touches the U's left arm at (4, 2) diagonally, so
    // everything is one component.
    assert_eq!(areas, vec![m.count()]);
}

#[test]
fn fragments_within_reach_join_into_one_component() {
    // Three pieces with gaps of 2 and 4 pixels between them.
    let mut m = Mask::zeros(40, 10).unwrap();
    for y in 2..6 {
        for x in (0..4).chain(6..10).chain(14..18) {
            m.set(x, y, true);
        }
    }
    let areas = |reach: u32| -> Vec<usize> {
        joined_components(&m, reach, 1, 10)
            .iter()
            .map(|c| c.area_px)
            .collect()
    };
    assert_eq!(areas(1), vec![16, 16, 16]);
    assert_eq!(largest_components(&m, 1, 10).len(), 3);
    assert_eq!(areas(2), vec![16, 16, 16], "a 2-pixel gap needs reach 3");
    assert_eq!(areas(3), vec![32, 16]);
    assert_eq!(areas(5), vec![48]);
    let joined = joined_components(&m, 5, 1, 10)[0];
    assert_eq!(
        joined.bbox,
        BoundingBox {
            x_min: 0,
            y_min: 2,
            x_max: 17,
            y_max: 5
        }
    );
    // Reach 0 is taken as plain 8-connectivity.
    assert_eq!(areas(0), areas(1));
}

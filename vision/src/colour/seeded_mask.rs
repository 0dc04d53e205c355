//! The ball's colour mask by hysteresis: pixels in the strict colour window are seeds, and
//! a region grows from them through 8-connected pixels of the wide window.
//!
//! One fixed window cannot serve every picture. A strict one loses a ball's shaded side,
//! its blurred rim and the pale pixels of a small far ball; a wide one takes in skin, wood
//! and warm-lit walls. Growing from seeds decides per picture, from the picture itself:
//! wide-window pixels count only when they touch a surely ball-coloured region, so the
//! ball keeps its whole outline while a pale look-alike with no strong orange in it stays
//! out. Nothing is carried from one picture to the next.
//!
//! One table answers both windows (two bits per colour cell, built like
//! [`crate::colour::hsv::MaskLut`]); the growth is a flood fill, linear in the pixels.

use crate::colour::hsv::{HsvError, HsvThresholds, MaskLut};
use crate::image::{Mask, RgbImage};

const SEED: u8 = 2;
const GROW: u8 = 1;

/// The seed and growth windows compiled into one lookup table.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SeededLut {
    /// Per colour cell: 2 seed, 1 growth only, 0 neither.
    classes: Vec<u8>,
}

impl SeededLut {
    /// Seeds from `seed`, growth through `grow` (a seed colour always grows too).
    pub fn new(seed: &HsvThresholds, grow: &HsvThresholds) -> Result<Self, HsvError> {
        let (seed, grow) = (MaskLut::new(seed)?, MaskLut::new(grow)?);
        let classes = seed
            .cells()
            .iter()
            .zip(grow.cells())
            .map(|(&s, &g)| if s != 0 { SEED } else { g * GROW })
            .collect();
        Ok(SeededLut { classes })
    }

    /// A pixel's class: 2 seed, 1 growth only, 0 neither.
    #[inline]
    fn class(&self, r: u8, g: u8, b: u8) -> u8 {
        self.classes[MaskLut::index(r, g, b)]
    }

    /// The grown mask of a picture: the seeds, and every growth pixel reached from a seed
    /// through at most `reach_px` steps between 8-neighbouring growth pixels (0: no limit).
    #[cfg(test)]
    pub fn apply(&self, image: &RgbImage, reach_px: u32) -> Mask {
        self.apply_with_seeds(image, reach_px).0
    }

    /// The grown mask, as [`SeededLut::apply`], and the seeds' own mask.
    pub fn apply_with_seeds(&self, image: &RgbImage, reach_px: u32) -> (Mask, Mask) {
        let (w, h) = (image.width() as usize, image.height() as usize);
        let mut class: Vec<u8> = image
            .data()
            .chunks_exact(3)
            .map(|p| self.class(p[0], p[1], p[2]))
            .collect();
        // Breadth first from every seed, one ring of steps at a time; a reached pixel is
        // marked as a seed so it is taken once.
        let mut ring: Vec<usize> = class
            .iter()
            .enumerate()
            .filter_map(|(i, &c)| (c == SEED).then_some(i))
            .collect();
        let mut seeds = vec![0u8; w * h];
        for &i in &ring {
            seeds[i] = 1;
        }
        let mut next = Vec::new();
        let mut steps = 0u32;
        while !ring.is_empty() && (reach_px == 0 || steps < reach_px) {
            for &i in &ring {
                let (x, y) = (i % w, i / w);
                for ny in y.saturating_sub(1)..=(y + 1).min(h - 1) {
                    for nx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                        let j = ny * w + nx;
                        if class[j] == GROW {
                            class[j] = SEED;
                            next.push(j);
                        }
                    }
                }
            }
            std::mem::swap(&mut ring, &mut next);
            next.clear();
            steps += 1;
        }
        let data = class.into_iter().map(|c| u8::from(c == SEED)).collect();
        (
            Mask::from_parts_unchecked(image.width(), image.height(), data),
            Mask::from_parts_unchecked(image.width(), image.height(), seeds),
        )
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn windows() -> (HsvThresholds, HsvThresholds) {
        let seed = HsvThresholds {
            hue_lo_deg: 10.0,
            hue_hi_deg: 40.0,
            sat_min: 0.6,
            sat_max: 1.0,
            val_min: 0.3,
            val_max: 1.0,
        };
        let grow = HsvThresholds {
            sat_min: 0.25,
            val_min: 0.1,
            ..seed
        };
        (seed, grow)
    }

    #[test]
    fn pale_pixels_count_only_next_to_strong_ones() {
        let (seed, grow) = windows();
        let lut = SeededLut::new(&seed, &grow).unwrap();
        let mut image = RgbImage::filled(12, 3, [40, 120, 40]).unwrap();
        // A strong orange pixel with a pale orange run to its right...
        image.set_pixel(1, 1, [230, 120, 20]);
        for x in 2..5 {
            image.set_pixel(x, 1, [200, 160, 120]);
        }
        // ... and a pale orange run on its own.
        for x in 8..11 {
            image.set_pixel(x, 1, [200, 160, 120]);
        }
        let mask = lut.apply(&image, 0);
        for x in 1..5 {
            assert!(mask.get(x, 1), "{x} should grow from the seed");
        }
        for x in 8..11 {
            assert!(!mask.get(x, 1), "{x} has no seed");
        }
        assert_eq!(mask.count(), 4);
        let (grown, seeds) = lut.apply_with_seeds(&image, 1);
        assert_eq!(seeds.count(), 1);
        assert_eq!(grown.count(), 2, "one step of growth");
    }

    #[test]
    fn the_seeds_alone_equal_the_strict_mask_when_nothing_grows() {
        let (seed, _) = windows();
        let lut = SeededLut::new(&seed, &seed).unwrap();
        let mut image = RgbImage::filled(5, 5, [0, 0, 0]).unwrap();
        image.set_pixel(2, 2, [230, 120, 20]);
        image.set_pixel(0, 4, [230, 120, 20]);
        assert_eq!(
            lut.apply(&image, 0),
            MaskLut::new(&seed).unwrap().apply(&image)
        );
    }
}

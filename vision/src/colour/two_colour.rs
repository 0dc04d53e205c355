//! The two-colour ball mask: a ball of the ball's colour with white patches (a patterned
//! football) as one round disc.
//!
//! In the ball-colour mask such a ball is a net of ball-coloured pieces around holes where
//! the patches are; the patches at the outline cut deep notches into it, and at the sizes a
//! MiRo sees the net is thin enough that the speckle opening breaks it. None of the steps
//! below lets white alone make anything, since each starts from the ball's colour:
//!
//! 1. Fragments of the ball's colour up to [`PatternConfig::join_reach_px`] pixels apart form
//!    one blob ([`crate::colour::components::joined_components`]).
//! 2. A blob that covers less than [`PatternConfig::max_box_fill`] of its bounding box may be
//!    a patterned ball (a disc, whole or cut by an edge, covers about π/4; a patterned
//!    ball's ball colour about 0.45; a wall marking seen at a slant 0.5 to 0.6). Its local
//!    view is grown by [`PatternConfig::view_growth`] so that the patches at the outline
//!    lie inside it. Any other blob (a plain ball) goes on exactly as before.
//! 3. In the view, the ball's colour grows into the pixels of the patches' colour
//!    ([`PatternConfig::white`]), at most [`PatternConfig::white_reach_px`] steps and never
//!    beyond its [`Hull`] (the disc around the blob's centroid reaching its farthest
//!    extent, grown by [`PatternConfig::hull_growth`]): the notches fill up
//!    ([`join_white`]).
//! 4. After the detector's closing, the background the mask encloses is filled
//!    ([`crate::colour::morphology::fill_holes`]): the patches inside the outline, whatever their
//!    colour (a patch on the shaded side is grey, as dark as the floor). An opening then
//!    smooths the outline ([`region_mask`]).
//!
//! The detector searches this mask for circles in addition to the closed ball colour, and
//! keeps a circle the ball colour alone gave where both find one, so a plain ball's circles
//! are the ones it always found. The colour check then accepts "ball
//! colour and the patches' colour" as a ball's colours when the ball's colour holds a
//! substantial share ([`crate::colour::kmeans`]).

use crate::colour::components::Component;
use crate::colour::hsv::{HsvError, HsvThresholds};
use crate::colour::morphology::{close, fill_holes, open};
use crate::image::Mask;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Largest reach the configuration accepts, pixels (it bounds the labelling cost).
pub const MAX_REACH_PX: u32 = 32;

/// Why a pattern configuration is unusable.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PatternError {
    #[error("{name} = {value} px is outside {min}..={max}")]
    BadReach {
        name: &'static str,
        value: u32,
        min: u32,
        max: u32,
    },
    #[error("{name} = {value} is outside [0, 1]")]
    BadFraction { name: &'static str, value: f64 },
    #[error(transparent)]
    White(#[from] HsvError),
}

/// Settings of the two-colour ball mask.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PatternConfig {
    /// Whether patterned balls are looked for at all (off: the plain ball's pipeline).
    pub enabled: bool,
    /// Ball-coloured pixels up to this far apart (along both axes) belong to one blob,
    /// pixels; 1 is plain 8-connectivity.
    pub join_reach_px: u32,
    /// Blobs covering less than this share of their bounding box are searched as patterned
    /// balls too, in [0, 1] (a disc covers π/4 of its box, a patterned ball's ball colour
    /// about 0.45; a wall marking seen at a slant 0.5 to 0.6).
    pub max_box_fill: f64,
    /// How many steps, pixels, the ball's colour grows into the patches' colour (0: never).
    pub white_reach_px: u32,
    /// Whether background enclosed by the ball's mask is filled.
    pub fill_holes: bool,
    /// Radius of the opening that smooths the outline of the filled mask, pixels (0 to
    /// skip).
    pub smooth_radius_px: u32,
    /// A possibly patterned blob's local view is grown by this fraction of the blob's
    /// size, in [0, 1].
    pub view_growth: f64,
    /// A possibly patterned blob's hull is grown by this fraction of its radius, in [0, 1].
    pub hull_growth: f64,
    /// The patches' colour window (hue in degrees, saturation and value 0..1).
    #[serde(deserialize_with = "white_over_default")]
    pub white: HsvThresholds,
}

/// A `white` table's missing keys keep the default patch colour's.
fn white_over_default<'de, D: serde::Deserializer<'de>>(
    deserializer: D,
) -> Result<HsvThresholds, D::Error> {
    HsvThresholds::deserialize_over(deserializer, PatternConfig::default().white)
}

impl Default for PatternConfig {
    /// White or light-grey patches.
    fn default() -> Self {
        PatternConfig {
            enabled: true,
            join_reach_px: 3,
            max_box_fill: 0.62,
            white_reach_px: 12,
            fill_holes: true,
            smooth_radius_px: 2,
            view_growth: 0.15,
            hull_growth: 0.05,
            white: HsvThresholds {
                hue_lo_deg: 0.0,
                hue_hi_deg: 360.0,
                sat_min: 0.0,
                sat_max: 0.3,
                val_min: 0.15,
                val_max: 1.0,
            },
        }
    }
}

impl PatternConfig {
    /// Checks the reaches' and fractions' ranges and the colour window.
    pub fn check(&self) -> Result<(), PatternError> {
        for (name, value, min) in [
            ("join_reach_px", self.join_reach_px, 1),
            ("white_reach_px", self.white_reach_px, 0),
            ("smooth_radius_px", self.smooth_radius_px, 0),
        ] {
            if !(min..=MAX_REACH_PX).contains(&value) {
                return Err(PatternError::BadReach {
                    name,
                    value,
                    min,
                    max: MAX_REACH_PX,
                });
            }
        }
        for (name, value) in [
            ("max_box_fill", self.max_box_fill),
            ("view_growth", self.view_growth),
            ("hull_growth", self.hull_growth),
        ] {
            if !(0.0..=1.0).contains(&value) {
                return Err(PatternError::BadFraction { name, value });
            }
        }
        self.white.check()?;
        Ok(())
    }

    /// The hull of a blob when it may be a patterned ball (patterned balls looked for, and
    /// the blob sparse in its box), grown by `hull_growth`; `None` otherwise.
    pub fn patterned_hull(&self, blob: &Component) -> Option<Hull> {
        if !self.enabled {
            return None;
        }
        let b = &blob.bbox;
        let box_px = f64::from(b.x_max - b.x_min + 1) * f64::from(b.y_max - b.y_min + 1);
        let hull = Hull::of(blob);
        (blob.area_px as f64 / box_px < self.max_box_fill).then_some(Hull {
            radius_px: hull.radius_px * (1.0 + self.hull_growth),
            ..hull
        })
    }
}

/// The disc around a blob's centroid that reaches its farthest extent along the image axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hull {
    pub centre_px: [f64; 2],
    pub radius_px: f64,
}

impl Hull {
    /// A blob's hull in the frame.
    pub fn of(blob: &Component) -> Hull {
        let b = &blob.bbox;
        let [cx, cy] = blob.centroid_px;
        let extent = [
            cx - f64::from(b.x_min),
            f64::from(b.x_max) - cx,
            cy - f64::from(b.y_min),
            f64::from(b.y_max) - cy,
        ];
        Hull {
            centre_px: blob.centroid_px,
            // A pixel reaches half a pixel past its centre.
            radius_px: extent.into_iter().fold(0.0, f64::max) + 0.5,
        }
    }

    fn contains(&self, x: usize, y: usize) -> bool {
        (x as f64 - self.centre_px[0]).hypot(y as f64 - self.centre_px[1]) <= self.radius_px
    }
}

/// The mask a possibly patterned ball gives in a region: the ball-colour mask `ball` grown
/// into the patch-coloured pixels (`white`, the same size) within `hull` (in the region's
/// pixels), closed with `close_radius_px`, its holes filled and its outline smoothed; the
/// closed ball colour is always part of it.
pub fn region_mask(
    ball: &Mask,
    white: &Mask,
    hull: &Hull,
    close_radius_px: u32,
    config: &PatternConfig,
) -> Mask {
    let closed = close(ball, close_radius_px);
    let grown = close(
        &join_white(ball, white, hull, config.white_reach_px),
        close_radius_px,
    );
    let filled = if config.fill_holes {
        fill_holes(&grown)
    } else {
        grown
    };
    let smooth = open(&filled, config.smooth_radius_px);
    let data = (closed.data().iter().zip(smooth.data()))
        .map(|(&c, &s)| c | s)
        .collect();
    Mask::from_parts_unchecked(ball.width(), ball.height(), data)
}

/// The ball-colour mask grown into the patch-coloured pixels (`white`, a mask of the same
/// size): up to `white_reach_px` steps (8-neighbour) from the ball's colour through the
/// patches' colour, and never outside `hull`.
pub fn join_white(ball: &Mask, white: &Mask, hull: &Hull, white_reach_px: u32) -> Mask {
    let (w, h) = (ball.width() as usize, ball.height() as usize);
    if white_reach_px == 0 || ball.width() != white.width() || ball.height() != white.height() {
        return ball.clone();
    }
    let mut grown = ball.data().to_vec();
    let mut front: Vec<usize> = (0..w * h).filter(|&i| grown[i] != 0).collect();
    let mut next = Vec::new();
    let wd = white.data();
    for _ in 0..white_reach_px {
        for &i in &front {
            let (x, y) = (i % w, i / w);
            for yy in y.saturating_sub(1)..=(y + 1).min(h - 1) {
                for xx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                    let j = yy * w + xx;
                    if grown[j] == 0 && wd[j] != 0 && hull.contains(xx, yy) {
                        grown[j] = 1;
                        next.push(j);
                    }
                }
            }
        }
        if next.is_empty() {
            break;
        }
        std::mem::swap(&mut front, &mut next);
        next.clear();
    }
    Mask::from_parts_unchecked(ball.width(), ball.height(), grown)
}

#[cfg(test)]
#[path = "two_colour_tests.rs"]
mod tests;

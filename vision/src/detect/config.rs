//! The detector's settings: colour windows, mask cleanup, blob and circle search, the
//! patterned ball's mask and the classifier's colour check. Every key is optional in a
//! settings file; a table with some keys keeps the defaults of the others.

use crate::appearance::AppearanceConfig;
use crate::candidates::PeakConfig;
use crate::colour::hough::HoughConfig;
use crate::colour::hsv::HsvThresholds;
use crate::colour::kmeans::ColourCheckConfig;
use crate::colour::two_colour::PatternConfig;
use serde::{Deserialize, Serialize};

/// Where the detector's candidates come from.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Proposer {
    /// The seed's path: the colour window's blobs and the circular Hough transform.
    #[default]
    Colour,
    /// Compact blobs that stand out from their surroundings, of any colour
    /// ([`crate::appearance`]).
    Appearance,
    /// Both, the colour path's first.
    Both,
    /// The candidate network's heatmap peaks ([`crate::candidates`]), then the
    /// strongest appearance proposals that do not repeat them.
    Net,
}

impl Proposer {
    pub fn colour(self) -> bool {
        matches!(self, Proposer::Colour | Proposer::Both)
    }

    pub fn appearance(self) -> bool {
        matches!(self, Proposer::Appearance | Proposer::Both | Proposer::Net)
    }

    /// Whether the candidate network runs.
    pub fn net(self) -> bool {
        matches!(self, Proposer::Net)
    }
}

/// The detector's settings.
/// Which classifier judges the proposals when no model file is given.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum ClassifierKind {
    /// The shipped ball network (any ball colour; refines the circle).
    Net,
    /// The shipped HOG + SVM filter with the colour check (the colour proposer's partner).
    #[default]
    HogSvm,
    /// The shipped grey checker (any ball colour, by shape; refines the circle; the
    /// candidate network's partner).
    Checker,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DetectorConfig {
    /// Where candidates come from: set by the detector the agent chose, never by a
    /// settings file.
    #[serde(skip)]
    pub proposer: Proposer,
    /// The shipped classifier that judges them (a model file given on the command line
    /// takes its place): set by the detector the agent chose, never by a settings file.
    #[serde(skip)]
    pub classifier: ClassifierKind,
    /// The appearance proposals' settings.
    pub appearance: AppearanceConfig,
    /// How the candidate network's peaks become candidates.
    pub candidates: PeakConfig,
    /// With the candidate network, at most this many appearance proposals join its peaks
    /// (the strongest).
    pub net_appearance_candidates: usize,
    /// The ball's colour window.
    #[serde(deserialize_with = "thresholds_over_default")]
    pub thresholds: HsvThresholds,
    /// The widest the colour window may become by lighting adaptation.
    #[serde(deserialize_with = "limits_over_default")]
    pub limits: HsvThresholds,
    /// Fraction of the way the thresholds move towards an accepted ball's colours.
    pub adapt_rate: f64,
    /// Radius of the speckle-removing opening, pixels (0 to skip).
    pub open_radius_px: u32,
    /// Radius of the hole-filling closing inside each region, pixels (0 to skip).
    pub close_radius_px: u32,
    /// Blobs smaller than this are ignored, pixels.
    pub min_blob_area_px: usize,
    /// At most this many blobs are searched for circles, largest first.
    pub max_blobs: usize,
    /// Margin added around each blob's box, pixels.
    pub roi_margin_px: u32,
    /// Grow the mask from the colour window's pixels through the wider `limits` window
    /// ([`crate::colour::seeded_mask`]), decided per image; otherwise the window alone.
    pub seeded: bool,
    /// How far the seeded mask grows from the strict window's pixels, pixels (0: as far
    /// as the wider window reaches).
    pub seeded_reach_px: u32,
    /// A blob whose larger side is at most this many pixels (a far ball) is proposed as
    /// its own circle when the Hough transform finds none in it.
    pub small_blob_max_px: u32,
    /// A roundish blob in which the Hough transform found no circle is proposed as its
    /// own circle ([`crate::colour::blob_circle`]).
    pub blob_fallback: bool,
    /// The circular Hough transform's settings.
    pub hough: HoughConfig,
    /// A patterned ball (the ball's colour with white patches): the two-colour mask.
    pub pattern: PatternConfig,
    /// The classifier's dominant-colour check.
    pub colour_check: ColourCheckConfig,
}

impl Default for DetectorConfig {
    /// An orange ball under ordinary indoor light.
    fn default() -> Self {
        DetectorConfig {
            proposer: Proposer::Colour,
            classifier: ClassifierKind::HogSvm,
            appearance: AppearanceConfig::default(),
            candidates: PeakConfig::default(),
            net_appearance_candidates: 4,
            thresholds: HsvThresholds {
                hue_lo_deg: 8.0,
                hue_hi_deg: 42.0,
                sat_min: 0.45,
                sat_max: 1.0,
                val_min: 0.1,
                val_max: 1.0,
            },
            limits: HsvThresholds {
                hue_lo_deg: 0.0,
                hue_hi_deg: 55.0,
                sat_min: 0.3,
                sat_max: 1.0,
                val_min: 0.06,
                val_max: 1.0,
            },
            adapt_rate: 0.1,
            open_radius_px: 1,
            close_radius_px: 2,
            min_blob_area_px: 9,
            max_blobs: 6,
            roi_margin_px: 4,
            seeded: true,
            seeded_reach_px: 4,
            small_blob_max_px: 9,
            blob_fallback: true,
            hough: HoughConfig::default(),
            pattern: PatternConfig::default(),
            colour_check: ColourCheckConfig::default(),
        }
    }
}

/// A `thresholds` table's missing keys keep the default window's.
fn thresholds_over_default<'de, D: serde::Deserializer<'de>>(
    deserializer: D,
) -> Result<HsvThresholds, D::Error> {
    HsvThresholds::deserialize_over(deserializer, DetectorConfig::default().thresholds)
}

/// A `limits` table's missing keys keep the default limits'.
fn limits_over_default<'de, D: serde::Deserializer<'de>>(
    deserializer: D,
) -> Result<HsvThresholds, D::Error> {
    HsvThresholds::deserialize_over(deserializer, DetectorConfig::default().limits)
}

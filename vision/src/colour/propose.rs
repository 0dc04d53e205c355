//! Stages `mask`, `cleanup`, `blobs` and `hough`: the colour path's proposals. The frame's
//! ball-colour mask through the lookup table (grown from the strict window's seeds),
//! opened; its blobs, joined across a pattern's gaps; each blob's circles by the circular
//! Hough transform in its local perspective view (with a camera model) or a window of the
//! frame, with a patterned ball's two-colour mask searched as well; and the proposals from
//! them, less fragments of bigger things.

use crate::camera::CameraModel;
use crate::circle::Circle;
use crate::colour::blob_circle::{
    blob_circle, blob_size_px, is_roundish, ring_share, shrink, unshrink,
};
use crate::colour::components::{BoundingBox, Component, joined_components};
use crate::colour::hough::HoughConfig;
use crate::colour::hsv::MaskLut;
use crate::colour::morphology::{close, open};
use crate::colour::rectify::{LocalView, MAX_HALF_SIDE_PX};
use crate::colour::two_colour::{Hull, region_mask};
use crate::detect::{DetectError, Detector, StageClock};
use crate::image::{ImageError, Mask, RgbImage};
use crate::proposal::{Proposal, Proposals};
use proto::CandidateStage;

impl Detector {
    /// The circles of a region's ball-colour mask, closed; for a possibly patterned ball
    /// (`patterned`: the region's patch-colour mask and the blob's hull in the region's
    /// pixels) also those of its two-colour mask.
    fn circles(
        &self,
        roi: Mask,
        patterned: Option<(Mask, Hull)>,
    ) -> Result<Vec<Circle>, DetectError> {
        let hough = |m: &Mask| {
            crate::colour::hough::detect(
                m.data(),
                m.width() as usize,
                m.height() as usize,
                &self.config.hough,
            )
        };
        let closed = close(&roi, self.config.close_radius_px);
        let mut circles = hough(&closed)?;
        if let Some((white, hull)) = patterned {
            let region = region_mask(
                &roi,
                &white,
                &hull,
                self.config.close_radius_px,
                &self.config.pattern,
            );
            if region != closed {
                // A circle the ball colour alone gave is kept as it was.
                let cfg = &self.config.hough;
                let new: Vec<Circle> = hough(&region)?
                    .into_iter()
                    .filter(|p| !circles.iter().any(|c| same_circle(c, p, cfg)))
                    .collect();
                circles.extend(new);
            }
        }
        Ok(circles)
    }

    /// The colour path's proposals, stage by stage: the ball-colour mask and its cleanup,
    /// the blobs in it, the circles of each blob (in its local view with a camera model, in
    /// the frame without), and the proposals from them, less fragments of bigger things.
    pub(crate) fn propose_colour(
        &self,
        image: &RgbImage,
        model: Option<&CameraModel>,
        clock: &mut dyn StageClock,
    ) -> Result<Proposals, DetectError> {
        let (mask, seeds) = self.colour_mask(image, clock);
        let blobs = self.colour_blobs(&mask, seeds.as_ref())?;
        clock.mark("blobs");
        let mut found = Vec::with_capacity(blobs.len());
        for blob in &blobs {
            found.extend(self.blob_circles(image, &mask, blob, model)?);
        }
        let mut proposals = assemble(found, image, model)?;
        // A circle with the ball's colours all round it is a fragment of something bigger.
        let fragment = |p: &Proposal| ring_share(image, &p.frame) > FRAGMENT_RING_SHARE;
        proposals.items.retain(|p| !fragment(p));
        clock.mark("hough");
        Ok(proposals)
    }

    /// Stages `mask` and `cleanup`: the pixels of the ball's colours, opened; with seeded
    /// growth, also the seeds it grew from.
    fn colour_mask(&self, image: &RgbImage, clock: &mut dyn StageClock) -> (Mask, Option<Mask>) {
        let cfg = &self.config;
        let (mask, seeds) = if cfg.seeded {
            let (grown, seeds) = self.seeded.apply_with_seeds(image, cfg.seeded_reach_px);
            (grown, Some(seeds))
        } else {
            (self.lut.apply(image), None)
        };
        clock.mark("mask");
        let mask = if cfg.open_radius_px > 0 {
            open(&mask, cfg.open_radius_px)
        } else {
            mask
        };
        clock.mark("cleanup");
        (mask, seeds)
    }

    /// The blobs of the mask, joined across a pattern's gaps; a big blob the growth made of
    /// a ball and its surroundings is searched again around its own seeds.
    fn colour_blobs(
        &self,
        mask: &Mask,
        seeds: Option<&Mask>,
    ) -> Result<Vec<Component>, DetectError> {
        let cfg = &self.config;
        let reach_px = if cfg.pattern.enabled {
            cfg.pattern.join_reach_px
        } else {
            1
        };
        let mut blobs = joined_components(mask, reach_px, cfg.min_blob_area_px, cfg.max_blobs);
        if let Some(seeds) = seeds {
            // A ball that the growth joined to a bigger region of ball-like colours (a warm
            // wall, a hand, a marking it touches) is searched again around its own seeds.
            let mut merged = Vec::new();
            for g in blobs.iter().filter(|g| {
                blob_size_px(g) > cfg.small_blob_max_px
                    && !is_roundish(g, FALLBACK_MAX_ASPECT, FALLBACK_MIN_FILL)
            }) {
                let b = &g.bbox;
                let window = crop(
                    seeds,
                    b.x_min,
                    b.y_min,
                    b.x_max - b.x_min + 1,
                    b.y_max - b.y_min + 1,
                )?;
                let (dx, dy) = (b.x_min, b.y_min);
                merged.extend(
                    joined_components(&window, reach_px, cfg.min_blob_area_px, cfg.max_blobs)
                        .into_iter()
                        .filter(|s| {
                            f64::from(blob_size_px(g))
                                > MERGED_SIZE_RATIO * f64::from(blob_size_px(s))
                        })
                        .map(|s| Component {
                            bbox: BoundingBox {
                                x_min: s.bbox.x_min + dx,
                                y_min: s.bbox.y_min + dy,
                                x_max: s.bbox.x_max + dx,
                                y_max: s.bbox.y_max + dy,
                            },
                            centroid_px: [
                                s.centroid_px[0] + f64::from(dx),
                                s.centroid_px[1] + f64::from(dy),
                            ],
                            ..s
                        }),
                );
            }
            merged.truncate(cfg.max_blobs);
            blobs.extend(merged);
        }
        Ok(blobs)
    }

    /// The circles of one blob: in its local view with a camera `model` (`None` when no
    /// view fits), else in the frame; with whether the blob is a patterned ball's.
    fn blob_circles(
        &self,
        image: &RgbImage,
        mask: &Mask,
        blob: &Component,
        model: Option<&CameraModel>,
    ) -> Result<Option<BlobCircles>, DetectError> {
        let cfg = &self.config;
        let m = cfg.roi_margin_px + cfg.close_radius_px;
        let hull = cfg.pattern.patterned_hull(blob);
        let growth = if hull.is_some() {
            cfg.pattern.view_growth
        } else {
            0.0
        };
        let size = blob_size_px(blob);
        let small = size <= cfg.small_blob_max_px;
        // A blob Hough may miss, as its own circle (in frame pixels), proposed when the
        // Hough transform finds nothing in it.
        let own = (small
            || (cfg.blob_fallback && is_roundish(blob, FALLBACK_MAX_ASPECT, FALLBACK_MIN_FILL)))
        .then(|| blob_circle(blob));
        let blob_view = BlobView {
            blob,
            hull,
            growth,
            margin_px: m,
            size_px: size,
            own,
        };
        match model {
            Some(model) => self.circles_in_view(image, mask, model, &blob_view),
            None => self.circles_in_frame(image, mask, &blob_view).map(Some),
        }
    }

    /// A blob's circles searched in its local perspective view, mapped to the view's centre.
    fn circles_in_view(
        &self,
        image: &RgbImage,
        mask: &Mask,
        model: &CameraModel,
        b: &BlobView<'_>,
    ) -> Result<Option<BlobCircles>, DetectError> {
        let (blob, hull, growth, m, size, own) =
            (b.blob, b.hull, b.growth, b.margin_px, b.size_px, b.own);
        let half = 0.5 * f64::from(size) * (1.0 + growth) + f64::from(m);
        // Big blobs are seen at a coarser scale, so the ball's radius stays
        // within the Hough transform's range.
        let max_half = (self.config.hough.r_max_px as u32 + m).min(MAX_HALF_SIDE_PX);
        let Some(view) = LocalView::fitting(model, blob.centroid_px, half, max_half) else {
            return Ok(None);
        };
        // The view looks at the blob's centroid through its centre pixel.
        let centre = f64::from(view.side() / 2);
        let in_view = |c: Circle| Circle {
            center_px: [centre, centre],
            radius_px: c.radius_px / view.scale(),
            ..c
        };
        let patterned = match (hull, &self.white_lut) {
            (Some(hull), Some(lut)) => Some((
                view.sample_lut(image, lut)?,
                Hull {
                    centre_px: [centre, centre],
                    radius_px: hull.radius_px / view.scale(),
                },
            )),
            _ => None,
        };
        let mut circles = self.circles(view.sample_mask(mask)?, patterned)?;
        if circles.is_empty() {
            circles.extend(own.map(in_view));
        }
        Ok(Some((Some(view), circles, hull.is_some())))
    }

    /// A blob's circles searched in a window of the frame around it, shrunk so the ball's
    /// radius is within the Hough transform's range.
    fn circles_in_frame(
        &self,
        image: &RgbImage,
        mask: &Mask,
        b: &BlobView<'_>,
    ) -> Result<BlobCircles, DetectError> {
        let (blob, hull, growth, m, size, own) =
            (b.blob, b.hull, b.growth, b.margin_px, b.size_px, b.own);
        let b = &blob.bbox;
        let m = m + (0.5 * f64::from(size) * growth).ceil() as u32;
        let x0 = b.x_min.saturating_sub(m);
        let y0 = b.y_min.saturating_sub(m);
        let x1 = (b.x_max + m).min(mask.width() - 1);
        let y1 = (b.y_max + m).min(mask.height() - 1);
        let (w, h) = (x1 - x0 + 1, y1 - y0 + 1);
        // Shrunk so that the ball's radius is within the Hough range.
        let k = (f64::from(size) / (1.8 * self.config.hough.r_max_px))
            .ceil()
            .max(1.0) as u32;
        let roi = shrink(&crop(mask, x0, y0, w, h)?, k);
        let patterned = match (hull, &self.white_lut) {
            (Some(hull), Some(lut)) => Some((
                shrink(&crop_lut(image, lut, x0, y0, w, h)?, k),
                Hull {
                    centre_px: [
                        (hull.centre_px[0] - f64::from(x0)) / f64::from(k),
                        (hull.centre_px[1] - f64::from(y0)) / f64::from(k),
                    ],
                    radius_px: hull.radius_px / f64::from(k),
                },
            )),
            _ => None,
        };
        let shift = |c: Circle| {
            let c = unshrink(c, k);
            Circle {
                center_px: [
                    c.center_px[0] + f64::from(x0),
                    c.center_px[1] + f64::from(y0),
                ],
                ..c
            }
        };
        let mut circles: Vec<Circle> = self
            .circles(roi, patterned)?
            .into_iter()
            .map(shift)
            .collect();
        if circles.is_empty() {
            circles.extend(own);
        }
        Ok((None, circles, hull.is_some()))
    }
}

/// A fallback blob must be about as wide as tall...
const FALLBACK_MAX_ASPECT: f64 = 1.6;
/// ... and fill most of its disc.
const FALLBACK_MIN_FILL: f64 = 0.55;

/// A seed blob inside a grown blob this many times its size was merged with something.
const MERGED_SIZE_RATIO: f64 = 1.6;

/// A blob with more of the ball's colours than this share around it is a fragment of
/// something bigger, not proposed as its own circle.
const FRAGMENT_RING_SHARE: f64 = 0.4;

/// A window of a mask.
fn crop(mask: &Mask, x0: u32, y0: u32, w: u32, h: u32) -> Result<Mask, ImageError> {
    let stride = mask.width() as usize;
    let mut data = Vec::with_capacity(w as usize * h as usize);
    for y in y0..y0 + h {
        let start = y as usize * stride + x0 as usize;
        data.extend_from_slice(&mask.data()[start..start + w as usize]);
    }
    Mask::new(w, h, data)
}

/// Whether two circles are one: centres closer than the Hough transform's smallest
/// distance and radii within a fifth of each other.
fn same_circle(a: &Circle, b: &Circle, hough: &HoughConfig) -> bool {
    let d = (a.center_px[0] - b.center_px[0]).hypot(a.center_px[1] - b.center_px[1]);
    d < hough.min_center_distance_px
        && (a.radius_px - b.radius_px).abs() <= 0.2 * a.radius_px.max(b.radius_px)
}

/// A window of a frame's colour mask through `lut`.
fn crop_lut(
    image: &RgbImage,
    lut: &MaskLut,
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
) -> Result<Mask, ImageError> {
    let mut data = Vec::with_capacity(w as usize * h as usize);
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            let [r, g, b] = image.pixel(x, y).unwrap_or([0; 3]);
            data.push(u8::from(lut.accepts(r, g, b)));
        }
    }
    Mask::new(w, h, data)
}

/// One blob's circles: the local view they are in (`None`: frame pixels) and whether the
/// blob is a patterned ball's.
type BlobCircles = (Option<LocalView>, Vec<Circle>, bool);

/// What the circle search needs of a blob.
struct BlobView<'a> {
    blob: &'a Component,
    hull: Option<Hull>,
    growth: f64,
    margin_px: u32,
    size_px: u32,
    own: Option<Circle>,
}

/// The colour stage's proposals from every blob's circles: in frame pixels, with the local view (kept
/// once per blob) and the angular radius when a camera model placed them.
fn assemble(
    found: Vec<BlobCircles>,
    image: &RgbImage,
    model: Option<&CameraModel>,
) -> Result<Proposals, DetectError> {
    let mut proposals = Proposals::default();
    for (view, circles, sparse_blob) in found {
        match (view, model) {
            (Some(view), Some(model)) => {
                if circles.is_empty() {
                    continue;
                }
                let index = proposals.views.len();
                proposals.views.push(view.sample_rgb(image)?);
                for c in circles {
                    let Some(center_px) = model.project(view.ray(c.center_px)) else {
                        continue;
                    };
                    proposals.items.push(Proposal {
                        frame: Circle {
                            center_px,
                            radius_px: c.radius_px * view.scale(),
                            ..c
                        },
                        local: c,
                        view: Some(index),
                        angular_radius_rad: Some(view.angular_radius_rad(c.center_px, c.radius_px)),
                        sparse_blob,
                        stage: CandidateStage::Colour,
                    });
                }
            }
            _ => proposals
                .items
                .extend(circles.into_iter().map(|c| Proposal {
                    frame: c,
                    local: c,
                    view: None,
                    angular_radius_rad: None,
                    sparse_blob,
                    stage: CandidateStage::Colour,
                })),
        }
    }
    Ok(proposals)
}

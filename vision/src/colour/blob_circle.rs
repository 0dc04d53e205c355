//! Circles straight from blobs, where the Hough transform cannot help, and masks shrunk
//! for blobs too big for it.
//!
//! - A far ball is a blob a few pixels wide: too few rim pixels for the Hough transform
//!   (which needs a radius of several pixels to vote), so a small blob is proposed as the
//!   circle of its own size around its centroid, and the classifier decides.
//! - A blob of the ball's colour that is round enough (about as wide as tall, filling most
//!   of the disc its box holds) but whose rim the Hough transform could not fit (a blurred
//!   ball, a speckled highlight, a cut-off edge) is proposed the same way.
//! - A close ball is bigger than the largest radius the Hough transform searches: its mask
//!   is shrunk by whole factors first ([`shrink`]), and the circles found scaled back.

use crate::circle::Circle;
use crate::colour::components::Component;
use crate::image::{Mask, RgbImage};

/// The larger side of a blob's box, pixels.
pub fn blob_size_px(blob: &Component) -> u32 {
    let b = &blob.bbox;
    (b.x_max - b.x_min).max(b.y_max - b.y_min) + 1
}

/// The blob as a circle around its centroid: the radius is the larger of the disc with
/// the blob's area and half its box's larger side. The score is the blob's fill of that
/// disc (1 for a full disc).
pub fn blob_circle(blob: &Component) -> Circle {
    let r_area = (blob.area_px as f64 / std::f64::consts::PI).sqrt();
    let r_box = 0.5 * f64::from(blob_size_px(blob));
    let radius_px = r_area.max(r_box).max(1.0);
    Circle {
        center_px: blob.centroid_px,
        radius_px,
        score: (blob.area_px as f64 / (std::f64::consts::PI * radius_px * radius_px)).min(1.0),
    }
}

/// Whether a blob looks like a disc: its box's sides within a factor of `max_aspect` of
/// each other and its pixels filling at least `min_fill` of the disc of [`blob_circle`].
pub fn is_roundish(blob: &Component, max_aspect: f64, min_fill: f64) -> bool {
    let b = &blob.bbox;
    let (w, h) = (
        f64::from(b.x_max - b.x_min + 1),
        f64::from(b.y_max - b.y_min + 1),
    );
    w.max(h) <= max_aspect * w.min(h) && blob_circle(blob).score >= min_fill
}

/// The share of points on two rings around a circle (at 1.5 and 2.2 radii, at least 2 and
/// 3 pixels out) whose colour is the circle's own (the hue within 20° and the saturation
/// within 0.25 of the mean colour inside 0.6 radii, neither dark nor grey) or a stronger
/// colour of the same family (within 40°, more saturated: a highlight on a red toy is a
/// pale orange disc with red all round). Points off the image are left out. A blob that is a fragment of a bigger object (a red toy's orange
/// rim, a patch of an orange wall marking) has its colour all round it; a ball has the
/// floor, a wall or a robot, which differ.
pub fn ring_share(image: &RgbImage, circle: &Circle) -> f64 {
    const POINTS: usize = 24;
    let [cx, cy] = circle.center_px;
    let inner = crate::colour::hsv::disc_hsv(image, circle, 0.6);
    if inner.is_empty() {
        return 0.0;
    }
    // The mean colour inside, by averaging unit hue vectors.
    let n = inner.len() as f64;
    let (mut hx, mut hy, mut sat) = (0.0, 0.0, 0.0);
    for &(h, s, _) in &inner {
        hx += s * h.to_radians().cos();
        hy += s * h.to_radians().sin();
        sat += s;
    }
    let hue = hy.atan2(hx).to_degrees().rem_euclid(360.0);
    let sat = sat / n;
    let (mut same, mut total) = (0usize, 0usize);
    for reach in [
        (1.5 * circle.radius_px).max(circle.radius_px + 2.0),
        (2.2 * circle.radius_px).max(circle.radius_px + 3.0),
    ] {
        for k in 0..POINTS {
            let a = std::f64::consts::TAU * k as f64 / POINTS as f64;
            let (x, y) = (
                (cx + reach * a.cos()).round(),
                (cy + reach * a.sin()).round(),
            );
            if x < 0.0 || y < 0.0 {
                continue;
            }
            if let Some([r, g, b]) = image.pixel(x as u32, y as u32) {
                total += 1;
                let (h, s, v) = crate::colour::hsv::rgb_to_hsv(r, g, b);
                let dh = (h - hue).rem_euclid(360.0);
                let dh = dh.min(360.0 - dh);
                let alike = dh <= 20.0 && (s - sat).abs() <= 0.25 && s > 0.25 && v > 0.15;
                let stronger = dh <= 40.0 && s >= 0.6 && s > sat && v > 0.3;
                same += usize::from(alike || stronger);
            }
        }
    }
    if total == 0 {
        return 0.0;
    }
    same as f64 / total as f64
}

/// The mask shrunk by a whole `factor`: an output pixel is set when at least half of its
/// `factor × factor` block is (a partial block at the right or bottom edge counts its
/// pixels inside the mask).
pub fn shrink(mask: &Mask, factor: u32) -> Mask {
    if factor <= 1 {
        return mask.clone();
    }
    let (w, h) = (mask.width(), mask.height());
    let (ow, oh) = (w.div_ceil(factor), h.div_ceil(factor));
    let mut data = Vec::with_capacity((ow * oh) as usize);
    for oy in 0..oh {
        for ox in 0..ow {
            let (mut set, mut total) = (0u32, 0u32);
            for y in oy * factor..((oy + 1) * factor).min(h) {
                for x in ox * factor..((ox + 1) * factor).min(w) {
                    total += 1;
                    set += u32::from(mask.get(x, y));
                }
            }
            data.push(u8::from(2 * set >= total && set > 0));
        }
    }
    Mask::from_parts_unchecked(ow, oh, data)
}

/// A circle found in a mask shrunk by `factor`, in the unshrunk mask's pixels.
pub fn unshrink(circle: Circle, factor: u32) -> Circle {
    let k = f64::from(factor.max(1));
    let offset = 0.5 * (k - 1.0);
    Circle {
        center_px: circle.center_px.map(|c| c * k + offset),
        radius_px: circle.radius_px * k,
        ..circle
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::colour::components::largest_components;

    fn disc(w: u32, h: u32, c: [f64; 2], r: f64) -> Mask {
        let mut m = Mask::zeros(w, h).unwrap();
        for y in 0..h {
            for x in 0..w {
                if (f64::from(x) - c[0]).hypot(f64::from(y) - c[1]) <= r {
                    m.set(x, y, true);
                }
            }
        }
        m
    }

    #[test]
    fn a_small_disc_is_its_own_circle() {
        let m = disc(20, 20, [7.0, 9.0], 2.5);
        let blob = largest_components(&m, 1, 1)[0];
        let c = blob_circle(&blob);
        assert!((c.center_px[0] - 7.0).abs() < 0.1 && (c.center_px[1] - 9.0).abs() < 0.1);
        assert!((c.radius_px - 2.5).abs() < 0.6, "{}", c.radius_px);
        assert!(is_roundish(&blob, 1.5, 0.6));
    }

    #[test]
    fn a_bar_is_not_roundish() {
        let mut m = Mask::zeros(30, 10).unwrap();
        for x in 2..28 {
            for y in 4..7 {
                m.set(x, y, true);
            }
        }
        let blob = largest_components(&m, 1, 1)[0];
        assert!(!is_roundish(&blob, 1.5, 0.6));
    }

    #[test]
    fn a_fragment_of_a_bigger_object_has_its_colour_all_round() {
        let mut image = RgbImage::filled(60, 60, [40, 140, 50]).unwrap();
        let circle = Circle {
            center_px: [30.0, 30.0],
            radius_px: 4.0,
            score: 1.0,
        };
        for y in 27..34 {
            for x in 27..34 {
                image.set_pixel(x, y, [230, 70, 30]);
            }
        }
        assert_eq!(ring_share(&image, &circle), 0.0);
        // A brown wall around it is not the same colour...
        for y in 10..50 {
            for x in 10..50 {
                if !(27..34).contains(&x) || !(27..34).contains(&y) {
                    image.set_pixel(x, y, [120, 90, 70]);
                }
            }
        }
        assert_eq!(ring_share(&image, &circle), 0.0);
        // ... a red toy is.
        for y in 10..50 {
            for x in 10..50 {
                if !(27..34).contains(&x) || !(27..34).contains(&y) {
                    image.set_pixel(x, y, [225, 50, 35]);
                }
            }
        }
        assert_eq!(ring_share(&image, &circle), 1.0);
    }

    #[test]
    fn shrinking_keeps_a_big_disc_round_and_unshrink_restores_it() {
        let m = disc(200, 200, [100.0, 90.0], 70.0);
        let small = shrink(&m, 4);
        assert_eq!((small.width(), small.height()), (50, 50));
        let blob = largest_components(&small, 1, 1)[0];
        let c = unshrink(blob_circle(&blob), 4);
        assert!((c.center_px[0] - 100.0).abs() < 2.0, "{:?}", c.center_px);
        assert!((c.center_px[1] - 90.0).abs() < 2.0, "{:?}", c.center_px);
        assert!((c.radius_px - 70.0).abs() < 4.0, "{}", c.radius_px);
    }
}

//! A grouped bar chart of fractions (0..1) as an RGB image, for the recall-by-size plot of
//! `evaluate`. The workspace's chart renderer lives in the evaluation crate, which depends
//! on this one, so the agent draws its one chart itself. It has no text: the groups are in
//! the order given, the bars of a group in the order of the series, grid lines every 25 %;
//! the command's report and documentation give the legend.

use anyhow::Result;
use robot_agent::image::RgbImage;

const W: u32 = 480;
const H: u32 = 300;
const MARGIN: u32 = 24;
const BACKGROUND: [u8; 3] = [255, 255, 255];
const GRID: [u8; 3] = [220, 220, 220];
const AXIS: [u8; 3] = [40, 40, 40];
/// Bar colours of the series, in order.
pub const SERIES_COLOURS: [[u8; 3]; 3] = [[31, 119, 180], [255, 127, 14], [44, 160, 44]];

fn fill(img: &mut RgbImage, x0: u32, y0: u32, x1: u32, y1: u32, c: [u8; 3]) {
    for y in y0..y1.min(img.height()) {
        for x in x0..x1.min(img.width()) {
            img.set_pixel(x, y, c);
        }
    }
}

/// `groups[g][s]` is series `s`'s fraction in group `g`; `None` draws no bar (nothing to
/// measure) but a short grey stub.
pub fn grouped_bars(groups: &[Vec<Option<f64>>]) -> Result<RgbImage> {
    let mut img = RgbImage::filled(W, H, BACKGROUND)?;
    let (left, right, top, bottom) = (MARGIN, W - MARGIN, MARGIN, H - MARGIN);
    let y_of = |v: f64| bottom - ((v.clamp(0.0, 1.0) * f64::from(bottom - top)).round() as u32);
    for k in 1..=4 {
        let y = y_of(f64::from(k) * 0.25);
        fill(&mut img, left, y, right, y + 1, GRID);
    }
    let n = groups.len().max(1) as u32;
    let group_w = (right - left) / n;
    for (g, series) in groups.iter().enumerate() {
        let s_n = series.len().max(1) as u32;
        let bar_w = (group_w * 3 / 4) / s_n;
        let x_start = left + g as u32 * group_w + group_w / 8;
        for (s, v) in series.iter().enumerate() {
            let x0 = x_start + s as u32 * bar_w;
            let colour = SERIES_COLOURS[s % SERIES_COLOURS.len()];
            match v {
                Some(v) => fill(&mut img, x0 + 1, y_of(*v), x0 + bar_w - 1, bottom, colour),
                None => fill(&mut img, x0 + 1, bottom - 3, x0 + bar_w - 1, bottom, GRID),
            }
        }
    }
    fill(&mut img, left, bottom, right, bottom + 2, AXIS);
    fill(&mut img, left - 2, top, left, bottom + 2, AXIS);
    Ok(img)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn bars_reach_their_fraction() {
        let img = grouped_bars(&[vec![Some(1.0), Some(0.5)], vec![None, Some(0.0)]]).unwrap();
        // The first group's first bar reaches the top grid line; the second is half as tall.
        let group_w = (W - 2 * MARGIN) / 2;
        let bar_w = (group_w * 3 / 4) / 2;
        let x = MARGIN + group_w / 8 + bar_w / 2;
        assert_eq!(img.pixel(x, MARGIN + 1), Some(SERIES_COLOURS[0]));
        let mid = (MARGIN + (H - MARGIN)) / 2;
        assert_eq!(img.pixel(x + bar_w, mid + 2), Some(SERIES_COLOURS[1]));
        assert_ne!(img.pixel(x + bar_w, mid - 2), Some(SERIES_COLOURS[1]));
    }
}

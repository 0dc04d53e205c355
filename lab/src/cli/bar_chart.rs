//! The recall-by-size plot of `evaluate`: a grouped bar chart of fractions (0..1), drawn
//! with plotters. The workspace's chart module lives in the evaluation crate, which depends
//! on this one, so the agent draws its one chart itself. Groups are the size bands of
//! `label_eval::SIZE_BANDS_PX` in order, the bars of a group the series in order; text is
//! drawn with the DejaVu Sans font embedded from `lab/assets/fonts`, so no system font is needed.

use std::sync::OnceLock;

use crate::labels::eval::band_name;
use anyhow::{Result, anyhow};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{FontStyle, register_font};
use vision::image::RgbImage;

const W: u32 = 640;
const H: u32 = 400;
const FONT: &str = "sans-serif";
use crate::CHART_FONT_TTF as FONT_TTF;
const GRID: RGBColor = RGBColor(220, 220, 220);
const INK: RGBColor = RGBColor(40, 40, 40);
/// Bar colours of the series, in order.
pub const SERIES_COLOURS: [[u8; 3]; 3] = [[31, 119, 180], [255, 127, 14], [44, 160, 44]];
/// The legend's names of the series, in order.
pub const SERIES_NAMES: [&str; 2] = ["published detection", "best candidate"];
/// Room above the plot for the title and the legend row, pixels.
const LEGEND_PX: u32 = 56;
/// Share of a group's width taken by its bars.
const BARS_SHARE: f64 = 0.75;

pub fn ensure_font() -> Result<()> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| register_font(FONT, FontStyle::Normal, FONT_TTF).is_ok());
    ok.then_some(())
        .ok_or_else(|| anyhow!("the embedded font cannot be read"))
}

/// `groups[g][s]` is series `s`'s fraction in size band `g`; `None` draws no bar (nothing
/// to measure) but a short grey stub.
pub fn grouped_bars(groups: &[Vec<Option<f64>>]) -> Result<RgbImage> {
    ensure_font()?;
    let mut rgb = vec![0; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (W, H)).into_drawing_area();
        draw(&root, groups).map_err(|e| anyhow!("cannot draw the bar chart: {e}"))?;
        root.present()
            .map_err(|e| anyhow!("cannot draw the bar chart: {e}"))?;
    }
    Ok(RgbImage::new(W, H, rgb)?)
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    groups: &[Vec<Option<f64>>],
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    // An integer range holds both ends: `0..last` is `groups.len()` segments.
    let last = groups.len().max(1) as u32 - 1;
    let title = (FONT, 18).into_font().color(&BLACK);
    let centre = Pos::new(HPos::Center, VPos::Center);
    root.draw(&Text::new(
        "Recall by ball width",
        (W as i32 / 2, 16),
        title.pos(centre),
    ))?;
    let mut chart = ChartBuilder::on(root)
        .margin(12)
        .margin_top(LEGEND_PX)
        .x_label_area_size(44)
        .y_label_area_size(60)
        .build_cartesian_2d((0..last).into_segmented(), 0.0..1.02f64)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_desc("ball width in the image (size band)")
        .y_desc("recall")
        .x_label_formatter(&|x| match x {
            SegmentValue::CenterOf(g) => band_name(*g as usize),
            _ => String::new(),
        })
        .y_labels(6)
        .y_label_formatter(&|y| format!("{:.0} %", y * 100.0))
        .label_style((FONT, 13).into_font().color(&INK))
        .axis_desc_style((FONT, 14).into_font().color(&INK))
        .bold_line_style(GRID)
        .light_line_style(TRANSPARENT)
        .draw()?;
    // Bars in pixels, placed from the chart's mapping: a segment's edges and a value's height.
    let px = |g: u32, v: f64| chart.backend_coord(&(SegmentValue::Exact(g), v));
    let series = groups.iter().map(Vec::len).max().unwrap_or(0);
    let colours: Vec<RGBColor> = (0..series)
        .map(|s| SERIES_COLOURS[s % SERIES_COLOURS.len()])
        .map(|[r, g, b]| RGBColor(r, g, b))
        .collect();
    let mut bars = Vec::new();
    for (k, values) in groups.iter().enumerate() {
        let ((left, bottom), (right, _)) = (px(k as u32, 0.0), px(k as u32 + 1, 0.0));
        let group_w = f64::from(right - left);
        let bar_w = group_w * BARS_SHARE / series as f64;
        for (s, value) in values.iter().enumerate() {
            let x0 = f64::from(left) + group_w * (1.0 - BARS_SHARE) / 2.0 + s as f64 * bar_w;
            let (top, style) = match value {
                Some(v) => (px(k as u32, v.clamp(0.0, 1.0)).1, colours[s].filled()),
                None => (bottom - 3, GRID.filled()),
            };
            let (x0, x1) = (x0.round() as i32 + 1, (x0 + bar_w).round() as i32 - 1);
            bars.push(Rectangle::new([(x0, top), (x1, bottom)], style));
        }
    }
    for bar in &bars {
        root.draw(bar)?;
    }
    // The legend: one row between the title and the plot, so it never hides a bar.
    let font = (FONT, 13).into_font().color(&INK);
    let (mut x, y) = (px(0, 0.0).0, LEGEND_PX as i32 - 16);
    for (s, colour) in colours.into_iter().enumerate() {
        let name = SERIES_NAMES.get(s).copied().unwrap_or("");
        root.draw(&Rectangle::new(
            [(x, y - 6), (x + 14, y + 6)],
            colour.filled(),
        ))?;
        let at = (x + 20, y);
        root.draw(&Text::new(
            name,
            at,
            font.pos(Pos::new(HPos::Left, VPos::Center)),
        ))?;
        x += 20 + root.estimate_text_size(name, &font)?.0 as i32 + 24;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// The longest vertical run of `colour` in any one column: a bar's height in pixels.
    fn bar_height(img: &RgbImage, colour: [u8; 3]) -> u32 {
        let mut best = 0;
        for x in 0..img.width() {
            let mut run = 0;
            for y in 0..img.height() {
                run = if img.pixel(x, y) == Some(colour) {
                    run + 1
                } else {
                    0
                };
                best = best.max(run);
            }
        }
        best
    }

    #[test]
    fn bars_reach_their_fraction() {
        let img = grouped_bars(&[vec![Some(1.0), Some(0.5)], vec![None, Some(0.0)]]).unwrap();
        let full = bar_height(&img, SERIES_COLOURS[0]);
        let half = bar_height(&img, SERIES_COLOURS[1]);
        assert!(full > 200, "full bar {full} px");
        let ratio = f64::from(half) / f64::from(full);
        assert!((ratio - 0.5).abs() < 0.03, "{half} / {full}");
    }

    #[test]
    fn text_is_drawn() {
        // Dark pixels left of the plot: the tick labels and the axis name.
        let img = grouped_bars(&[vec![Some(0.3), Some(0.6)]]).unwrap();
        let dark = (0..60)
            .flat_map(|x| (0..H).map(move |y| (x, y)))
            .filter(|&(x, y)| img.pixel(x, y).is_some_and(|p| p.iter().all(|&c| c < 120)))
            .count();
        assert!(dark > 100, "{dark} dark pixels");
    }
}

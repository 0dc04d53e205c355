//! The precision-recall plot of `evaluate` and `train`: image recall against precision as
//! the probability threshold falls, one line per curve, with the threshold in use marked.

use crate::labels::eval::PrPoint;
use anyhow::{Result, anyhow};
use plotters::coord::Shift;
use plotters::prelude::*;
use vision::image::RgbImage;

const W: u32 = 640;
const H: u32 = 440;
const FONT: &str = "sans-serif";
const INK: RGBColor = RGBColor(40, 40, 40);
const GRID: RGBColor = RGBColor(220, 220, 220);

/// One curve: its name, its points and the operating threshold to mark.
pub struct Curve<'a> {
    pub name: &'a str,
    pub points: &'a [PrPoint],
    pub threshold: f64,
}

/// The curves drawn on one chart.
pub fn pr_chart(title: &str, curves: &[Curve<'_>]) -> Result<RgbImage> {
    super::bar_chart::ensure_font()?;
    let mut rgb = vec![0; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (W, H)).into_drawing_area();
        draw(&root, title, curves).map_err(|e| anyhow!("cannot draw the PR curve: {e}"))?;
        root.present()
            .map_err(|e| anyhow!("cannot draw the PR curve: {e}"))?;
    }
    Ok(RgbImage::new(W, H, rgb)?)
}

/// One curve drawn and written to `path` as a PNG (its folder made).
pub fn write_png(path: &std::path::Path, title: &str, curve: Curve<'_>) -> Result<()> {
    let chart = pr_chart(title, &[curve])?;
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)?;
    }
    std::fs::write(path, robot_agent::encode_png(&chart)?)
        .map_err(|e| anyhow!("writing {}: {e}", path.display()))
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    curves: &[Curve<'_>],
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(root)
        .margin(14)
        .caption(title, (FONT, 18).into_font().color(&BLACK))
        .x_label_area_size(44)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..1.0f64, 0.0..1.02f64)?;
    chart
        .configure_mesh()
        .x_desc("recall (photos with a ball whose published detection is on it)")
        .y_desc("precision")
        .x_label_formatter(&|x| format!("{:.0} %", x * 100.0))
        .y_label_formatter(&|y| format!("{:.0} %", y * 100.0))
        .label_style((FONT, 13).into_font().color(&INK))
        .axis_desc_style((FONT, 14).into_font().color(&INK))
        .bold_line_style(GRID)
        .light_line_style(TRANSPARENT)
        .draw()?;
    for (k, curve) in curves.iter().enumerate() {
        let [r, g, b] =
            super::bar_chart::SERIES_COLOURS[k % super::bar_chart::SERIES_COLOURS.len()];
        let colour = RGBColor(r, g, b);
        chart
            .draw_series(LineSeries::new(
                curve.points.iter().map(|p| (p.recall, p.precision)),
                colour.stroke_width(2),
            ))?
            .label(curve.name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
            });
        // The operating point: the last point at or above the threshold.
        if let Some(p) = curve
            .points
            .iter()
            .take_while(|p| p.threshold >= curve.threshold)
            .last()
        {
            chart.draw_series(std::iter::once(Circle::new(
                (p.recall, p.precision),
                5,
                colour.filled(),
            )))?;
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .label_font((FONT, 13).into_font().color(&INK))
        .background_style(WHITE.mix(0.9))
        .border_style(GRID)
        .draw()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn the_curve_is_drawn() {
        let points = [
            PrPoint {
                threshold: 0.9,
                recall: 0.2,
                precision: 1.0,
            },
            PrPoint {
                threshold: 0.5,
                recall: 0.8,
                precision: 0.9,
            },
        ];
        let img = pr_chart(
            "held-out",
            &[Curve {
                name: "ball net",
                points: &points,
                threshold: 0.5,
            }],
        )
        .unwrap();
        let [r, g, b] = crate::cli::bar_chart::SERIES_COLOURS[0];
        let coloured = (0..W)
            .flat_map(|x| (0..H).map(move |y| (x, y)))
            .filter(|&(x, y)| img.pixel(x, y) == Some([r, g, b]))
            .count();
        assert!(coloured > 300, "{coloured} pixels of the curve's colour");
    }
}

//! A [`Chart`] as plotters calls, for any backend: title band, mesh with tick labels and
//! axis names, rectangle outlines, series, and the legend in the emptiest corner.

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{Chart, FONT, Frame, MARGIN, Marker, PlotError, Style, X_AREA_PX, Y_AREA_PX};

const TITLE_SIZE: u32 = 20;
const LABEL_SIZE: u32 = 14;
const DESC_SIZE: u32 = 16;
const LINE_WIDTH: u32 = 2;
const INK: RGBColor = RGBColor(40, 40, 40);
const GRID: RGBColor = RGBColor(228, 228, 228);

type Drawn<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// Draws the whole chart onto `root`, which has the frame's size.
pub(super) fn chart<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    chart: &Chart,
    frame: &Frame,
) -> Result<(), PlotError> {
    draw_all(root, chart, frame).map_err(|e| PlotError::Draw(e.to_string()))
}

fn draw_all<'a, DB: DrawingBackend + 'a>(
    root: &'a DrawingArea<DB, Shift>,
    chart: &Chart,
    frame: &Frame,
) -> Drawn<DB> {
    root.fill(&WHITE)?;
    let (title, body) = root.split_vertically(frame.title_px);
    if !chart.title.is_empty() {
        let style = (FONT, TITLE_SIZE)
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(HPos::Center, VPos::Center));
        let at = (
            (frame.width / 2) as i32,
            (frame.title_px / 2 + MARGIN / 2) as i32,
        );
        title.draw(&Text::new(chart.title.as_str(), at, style))?;
    }
    let mut cc = ChartBuilder::on(&body)
        .margin_top(MARGIN)
        .margin_bottom(MARGIN)
        .margin_left(MARGIN)
        .margin_right(2 * MARGIN)
        .x_label_area_size(X_AREA_PX)
        .y_label_area_size(Y_AREA_PX)
        .build_cartesian_2d(frame.x.0..frame.x.1, frame.y.0..frame.y.1)?;
    cc.configure_mesh()
        .x_desc(chart.x_label.as_str())
        .y_desc(chart.y_label.as_str())
        .x_labels(10)
        .y_labels(8)
        .label_style((FONT, LABEL_SIZE).into_font().color(&INK))
        .axis_desc_style((FONT, DESC_SIZE).into_font().color(&INK))
        .axis_style(RGBColor(110, 110, 110))
        .bold_line_style(GRID)
        .light_line_style(TRANSPARENT)
        .draw()?;
    let clip = |run: &[(f64, f64)]| super::clip::clip_polyline(run, frame.x, frame.y);
    for r in &chart.rects {
        let style = rgb(r.color).stroke_width(LINE_WIDTH);
        for piece in clip(&r.corners()) {
            cc.draw_series(std::iter::once(PathElement::new(piece, style)))?;
        }
    }
    for s in &chart.series {
        let color = rgb(s.color);
        let line = color.stroke_width(LINE_WIDTH);
        if !matches!(s.style, Style::Markers(_)) {
            for piece in s.runs().flat_map(clip) {
                match (piece.len(), s.style) {
                    // A lone point would be invisible as a line; show it as a dot.
                    (1, _) => {
                        cc.draw_series(std::iter::once(Circle::new(piece[0], 4, color.filled())))?;
                    }
                    (_, Style::Dashed) => {
                        cc.draw_series(DashedLineSeries::new(piece, 8, 6, line))?;
                    }
                    _ => {
                        cc.draw_series(LineSeries::new(piece, line))?;
                    }
                }
            }
        }
        if let Style::Markers(m) | Style::LineAndMarkers(m) = s.style {
            let glyph = Glyph::marker(m);
            let shown = s.runs().flatten().copied();
            let shown = shown.filter(|&p| super::clip::inside(p, frame.x, frame.y));
            cc.draw_series(shown.map(|p| {
                EmptyElement::at(p)
                    + Polygon::new(glyph.fill.clone(), color.filled())
                    + PathElement::new(glyph.strokes[0].clone(), line)
                    + PathElement::new(glyph.strokes[1].clone(), line)
            }))?;
        }
    }
    legend(&mut cc, chart, frame)
}

/// One legend row per labelled series, drawn as its line and marker.
fn legend<'a, DB: DrawingBackend + 'a>(
    cc: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    chart: &Chart,
    frame: &Frame,
) -> Drawn<DB> {
    let labelled: Vec<_> = chart
        .series
        .iter()
        .filter(|s| !s.label.is_empty())
        .collect();
    if labelled.is_empty() {
        return Ok(());
    }
    for s in &labelled {
        let (glyph, color) = (Glyph::legend(s.style), rgb(s.color));
        let line = color.stroke_width(LINE_WIDTH);
        // Nothing to draw in the plot: this only adds the legend row.
        cc.draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?
            .label(s.label.as_str())
            .legend(move |at| {
                let [a, b, c, d] = glyph.strokes.clone();
                EmptyElement::at(at)
                    + Polygon::new(glyph.fill.clone(), color.filled())
                    + PathElement::new(a, line)
                    + PathElement::new(b, line)
                    + PathElement::new(c, line)
                    + PathElement::new(d, line)
            });
    }
    let chars = labelled
        .iter()
        .map(|s| s.label.chars().count())
        .max()
        .unwrap_or(0);
    let w = 50.0 + chars as f64 * 0.6 * f64::from(LABEL_SIZE);
    let h = 20.0 + labelled.len() as f64 * 1.25 * f64::from(LABEL_SIZE);
    cc.configure_series_labels()
        .position(super::legend_corner(chart, frame, w, h))
        .label_font((FONT, LABEL_SIZE).into_font().color(&INK))
        .background_style(WHITE)
        .border_style(RGBColor(190, 190, 190))
        .draw()
}

/// A series' sample drawn in pixel offsets around a point: a filled outline and
/// up to four stroked paths (unused ones are empty and draw nothing). One shape for all
/// markers and legend samples keeps the element type the same whatever the style.
#[derive(Debug, Clone, Default)]
struct Glyph {
    fill: Vec<(i32, i32)>,
    strokes: [Vec<(i32, i32)>; 4],
}

impl Glyph {
    /// A marker centred on the point.
    fn marker(m: Marker) -> Glyph {
        match m {
            Marker::Circle => Glyph {
                fill: (0..16)
                    .map(|k| {
                        let a = f64::from(k) * std::f64::consts::PI / 8.0;
                        (
                            (4.5 * a.cos()).round() as i32,
                            (4.5 * a.sin()).round() as i32,
                        )
                    })
                    .collect(),
                ..Glyph::default()
            },
            Marker::Cross => Glyph {
                strokes: [
                    vec![(-5, -5), (5, 5)],
                    vec![(-5, 5), (5, -5)],
                    Vec::new(),
                    Vec::new(),
                ],
                ..Glyph::default()
            },
            Marker::Square => Glyph {
                fill: vec![(-4, -4), (4, -4), (4, 4), (-4, 4)],
                ..Glyph::default()
            },
            Marker::Diamond => Glyph {
                fill: vec![(0, -6), (6, 0), (0, 6), (-6, 0)],
                ..Glyph::default()
            },
        }
    }

    /// The legend sample: a short line (dashed for dashed series) with the marker on it.
    fn legend(style: Style) -> Glyph {
        let shift = |v: Vec<(i32, i32)>| v.into_iter().map(|(x, y)| (x + 12, y)).collect();
        let mut g = match style {
            Style::Markers(m) | Style::LineAndMarkers(m) => Glyph::marker(m),
            Style::Line | Style::Dashed => Glyph::default(),
        };
        g.fill = shift(g.fill);
        let [a, b, _, _] = g.strokes;
        let (c, d) = match style {
            Style::Markers(_) => (Vec::new(), Vec::new()),
            Style::Dashed => (vec![(0, 0), (8, 0)], vec![(15, 0), (24, 0)]),
            Style::Line | Style::LineAndMarkers(_) => (vec![(0, 0), (24, 0)], Vec::new()),
        };
        g.strokes = [shift(a), shift(b), c, d];
        g
    }
}

fn rgb(c: [u8; 3]) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

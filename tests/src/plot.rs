//! Minimal chart renderer for evaluation plots: line, dashed and marker series drawn
//! into an RGB raster and saved as PNG.
//!
//! It is self-contained (a built-in bitmap font, no system fonts, only the `png`
//! crate) so the evaluation binary produces the same images on every machine.
//! lib.rs only needs `pub mod plot;`: the sibling files `plot_font.rs` (glyph table)
//! and `plot_raster.rs` (drawing primitives) are pulled in below as child modules.

use std::fmt;
use std::path::Path;

#[path = "plot_font.rs"]
mod font;
#[path = "plot_raster.rs"]
mod raster;

use raster::{Canvas, LINE_WIDTH, Occupancy, Pt, Rect, text_height, text_width};

/// Distinguishable colours (Tableau 10), handy for picking series colours in order.
pub const PALETTE: [[u8; 3]; 8] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [127, 127, 127],
];

/// Shape drawn at each data point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    Circle,
    Cross,
    Square,
    Diamond,
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    Line,
    Markers(Marker),
    LineAndMarkers(Marker),
    Dashed,
}

/// One labelled set of points. Non-finite points are skipped; in line styles they
/// break the line, so a NaN can separate unrelated segments.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    pub label: String,
    pub color: [u8; 3],
    pub style: Style,
    pub points: Vec<(f64, f64)>,
}

impl Series {
    pub fn new(
        label: impl Into<String>,
        color: [u8; 3],
        style: Style,
        points: Vec<(f64, f64)>,
    ) -> Self {
        Self {
            label: label.into(),
            color,
            style,
            points,
        }
    }
}

/// An axis-aligned rectangle outline in data coordinates (e.g. the pitch walls).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RectOutline {
    pub x0: f64,
    pub y0: f64,
    pub x1: f64,
    pub y1: f64,
    pub color: [u8; 3],
}

impl RectOutline {
    /// The corners in drawing order, closing the loop.
    fn corners(&self) -> [Pt; 5] {
        let (a, b, c, d) = (
            (self.x0, self.y0),
            (self.x1, self.y0),
            (self.x1, self.y1),
            (self.x0, self.y1),
        );
        [a, b, c, d, a]
    }
}

/// Everything needed to draw one chart. Fields are public so callers can build it
/// directly; [`Chart::new`] supplies the defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct Chart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    /// Image size; clamped to `MIN_SIZE..=MAX_SIZE` so odd values cannot panic.
    pub width_px: u32,
    pub height_px: u32,
    /// `None` autoscales to the data (series and rects) plus 5 % padding.
    pub x_range: Option<(f64, f64)>,
    pub y_range: Option<(f64, f64)>,
    /// One data unit spans the same number of pixels on both axes; the axis with
    /// spare room gets its range widened (centred), so explicit ranges may grow.
    pub equal_aspect: bool,
    pub series: Vec<Series>,
    pub rects: Vec<RectOutline>,
}

impl Chart {
    /// A 900×560 chart with autoscaled axes and no series.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            width_px: 900,
            height_px: 560,
            x_range: None,
            y_range: None,
            equal_aspect: false,
            series: Vec::new(),
            rects: Vec::new(),
        }
    }
}

/// A rendered image: `pixels` holds `width * height` RGB triples, row-major from the top.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RgbImage {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<u8>,
}

/// Why writing a PNG failed.
#[derive(Debug)]
pub enum PlotError {
    Io(std::io::Error),
    Png(png::EncodingError),
}

impl fmt::Display for PlotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Io(e) => write!(f, "cannot write plot file: {e}"),
            Self::Png(e) => write!(f, "cannot encode plot as PNG: {e}"),
        }
    }
}

impl std::error::Error for PlotError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Io(e) => Some(e),
            Self::Png(e) => Some(e),
        }
    }
}

impl From<std::io::Error> for PlotError {
    fn from(e: std::io::Error) -> Self {
        Self::Io(e)
    }
}

impl From<png::EncodingError> for PlotError {
    fn from(e: png::EncodingError) -> Self {
        Self::Png(e)
    }
}

/// Smallest image edge; below this the layout has no room for a plot area.
pub const MIN_SIZE: u32 = 160;
/// Largest image edge, so a typo cannot allocate gigabytes.
pub const MAX_SIZE: u32 = 8192;

const TEXT_SCALE: i32 = 2;
const PAD: i32 = 10;
const WHITE: [u8; 3] = [255, 255, 255];
const INK: [u8; 3] = [40, 40, 40];
const FRAME: [u8; 3] = [110, 110, 110];
const GRID: [u8; 3] = [228, 228, 228];

/// Renders the chart into memory; never panics, whatever the data.
pub fn render_rgb(chart: &Chart) -> RgbImage {
    let w = chart.width_px.clamp(MIN_SIZE, MAX_SIZE);
    let h = chart.height_px.clamp(MIN_SIZE, MAX_SIZE);
    let mut canvas = Canvas::new(w as i32, h as i32);
    let frame = Frame::layout(chart, w as i32, h as i32);
    draw_chart(&mut canvas, chart, &frame);
    RgbImage {
        width: w,
        height: h,
        pixels: canvas.px,
    }
}

/// Renders the chart and writes it to `path` as an 8-bit RGB PNG.
pub fn write_png(chart: &Chart, path: &Path) -> Result<(), PlotError> {
    let img = render_rgb(chart);
    // Encoding into memory first means every I/O error surfaces from `fs::write`
    // instead of being swallowed when a buffered writer is dropped.
    let mut bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut bytes, img.width, img.height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(&img.pixels)?;
    writer.finish()?;
    std::fs::write(path, bytes)?;
    Ok(())
}

/// Tick positions at a "nice" step (1, 2 or 5 × 10^k) inside `lo..=hi`, aiming for
/// 4–8 ticks (ideally about 6). Returns the step too, which decides label precision.
fn nice_ticks(lo: f64, hi: f64) -> (f64, Vec<f64>) {
    let span = hi - lo;
    if !(span.is_finite() && span > 0.0) {
        return (1.0, if lo.is_finite() { vec![lo] } else { Vec::new() });
    }
    let base = 10f64.powf((span / 6.0).log10().floor());
    let count = |step: f64| ((hi / step + 1e-9).floor() - (lo / step - 1e-9).ceil() + 1.0).max(0.0);
    let badness = |n: f64| (4.0 - n).max(n - 8.0).max(0.0) * 10.0 + (n - 6.0).abs();
    let step = [0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0]
        .iter()
        .map(|m| m * base)
        .min_by(|a, b| badness(count(*a)).total_cmp(&badness(count(*b))))
        .unwrap_or(base);
    let first = (lo / step - 1e-9).ceil();
    let n = count(step).min(100.0) as usize;
    (step, (0..n).map(|i| (first + i as f64) * step).collect())
}

/// Formats a tick so every label on an axis has just enough decimals for `step`.
fn format_tick(v: f64, step: f64) -> String {
    let v = if v.abs() < step * 1e-6 { 0.0 } else { v }; // avoid "-0.0" and 1e-17
    if v.abs() >= 1e6 || step < 1e-4 {
        return format!("{v:.1e}");
    }
    let decimals = (-(step.log10() + 1e-9).floor()).max(0.0) as usize;
    format!("{v:.decimals$}")
}

/// One axis after autoscaling: its data range and labelled ticks.
#[derive(Debug, Clone, PartialEq)]
struct Axis {
    lo: f64,
    hi: f64,
    ticks: Vec<(f64, String)>,
}

impl Axis {
    fn new(lo: f64, hi: f64) -> Self {
        let (step, ticks) = nice_ticks(lo, hi);
        let ticks = ticks
            .into_iter()
            .map(|t| (t, format_tick(t, step)))
            .collect();
        Self { lo, hi, ticks }
    }
    fn label_width(&self) -> i32 {
        self.ticks
            .iter()
            .map(|(_, s)| text_width(s, TEXT_SCALE))
            .max()
            .unwrap_or(0)
    }
}

/// The plot area in pixels and the axes mapped onto it.
#[derive(Debug, Clone, PartialEq)]
struct Frame {
    plot: Rect,
    x: Axis,
    y: Axis,
}

impl Frame {
    /// Places the plot area inside the margins left for title, labels and ticks.
    /// With equal aspect the y range changes after the first pass, and with it the
    /// width of the y tick labels, so the plot area is placed a second time.
    fn layout(chart: &Chart, w: i32, h: i32) -> Frame {
        let (xb, yb) = data_bounds(chart);
        let (xr, yr) = (
            resolve_range(chart.x_range, xb),
            resolve_range(chart.y_range, yb),
        );
        let mut plot = plot_area(chart, &Axis::new(yr.0, yr.1), w, h);
        let (mut x, mut y) = (xr, yr);
        if chart.equal_aspect {
            let (_, first_y) = equalise(xr, yr, plot);
            plot = plot_area(chart, &Axis::new(first_y.0, first_y.1), w, h);
            (x, y) = equalise(xr, yr, plot);
        }
        let (x, y) = (Axis::new(x.0, x.1), Axis::new(y.0, y.1));
        Frame { plot, x, y }
    }

    fn to_px(&self, p: Pt) -> Pt {
        let fx = (p.0 - self.x.lo) / (self.x.hi - self.x.lo);
        let fy = (p.1 - self.y.lo) / (self.y.hi - self.y.lo);
        (
            self.plot.x0 + fx * (self.plot.x1 - self.plot.x0),
            self.plot.y1 - fy * (self.plot.y1 - self.plot.y0),
        )
    }
}

/// The plot rectangle: what is left after the title, the rotated y label, the y
/// tick labels, the x tick labels and the x label have taken their space.
fn plot_area(chart: &Chart, y: &Axis, w: i32, h: i32) -> Rect {
    let th = text_height(TEXT_SCALE);
    let title = if chart.title.is_empty() { 0 } else { th + PAD };
    let y_label = if chart.y_label.is_empty() {
        0
    } else {
        th + PAD
    };
    let x_label = if chart.x_label.is_empty() { 0 } else { th + 6 };
    let (left, top) = (PAD + y_label + y.label_width() + 10, PAD + title);
    let (right, bottom) = (w - 2 * PAD, h - PAD - th - 8 - x_label);
    let (l, t) = (f64::from(left.min(w / 2)), f64::from(top.min(h / 2)));
    let (r, b) = (
        f64::from(right).max(l + 1.0),
        f64::from(bottom).max(t + 1.0),
    );
    Rect {
        x0: l,
        y0: t,
        x1: r,
        y1: b,
    }
}

/// Extent of all finite series points and rectangle corners, per axis.
fn data_bounds(chart: &Chart) -> (Option<Pt>, Option<Pt>) {
    let rect_pts = chart
        .rects
        .iter()
        .flat_map(|r| [(r.x0, r.y0), (r.x1, r.y1)]);
    let pts = chart
        .series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .chain(rect_pts);
    let grow = |acc: Option<Pt>, v: f64| match acc {
        _ if !v.is_finite() => acc,
        None => Some((v, v)),
        Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
    };
    pts.filter(|p| p.0.is_finite() && p.1.is_finite())
        .fold((None, None), |(x, y), p| (grow(x, p.0), grow(y, p.1)))
}

/// Chooses an axis range: the explicit one if usable, else the data plus 5 %
/// padding, widening empty or zero-width ranges so the mapping never divides by 0.
fn resolve_range(explicit: Option<Pt>, data: Option<Pt>) -> Pt {
    let (lo, hi) = match (explicit, data) {
        (Some((a, b)), _) if a.is_finite() && b.is_finite() => return widen(a.min(b), a.max(b)),
        (_, Some((lo, hi))) => widen(lo, hi),
        _ => (0.0, 1.0),
    };
    let pad = (hi - lo) * 0.05;
    (lo - pad, hi + pad)
}

/// Gives a zero-width range some width and caps huge ones so their span stays
/// finite: the data-to-pixel mapping divides by the span.
fn widen(lo: f64, hi: f64) -> Pt {
    const LIMIT: f64 = f64::MAX / 4.0;
    let (lo, hi) = (lo.clamp(-LIMIT, LIMIT), hi.clamp(-LIMIT, LIMIT));
    if hi - lo > 1e-12 * lo.abs().max(hi.abs()) && hi > lo {
        return (lo, hi);
    }
    let d = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
    (lo - d, hi + d)
}

/// Widens one range (about its centre) so both axes share one pixels-per-unit scale.
fn equalise(x: Pt, y: Pt, plot: Rect) -> (Pt, Pt) {
    let (pw, ph) = (plot.x1 - plot.x0, plot.y1 - plot.y0);
    let unit = ((x.1 - x.0) / pw).max((y.1 - y.0) / ph);
    if !unit.is_finite() || unit <= 0.0 {
        return (x, y);
    }
    let centred = |r: Pt, px: f64| {
        let (c, half) = ((r.0 + r.1) * 0.5, unit * px * 0.5);
        (c - half, c + half)
    };
    (centred(x, pw), centred(y, ph))
}

/// Paints back to front: grid, then data clipped to the plot area, then the frame
/// and text over the data edges, and the legend last so nothing hides it.
fn draw_chart(canvas: &mut Canvas, chart: &Chart, frame: &Frame) {
    draw_grid(canvas, frame);
    canvas.clip = frame.plot;
    for r in &chart.rects {
        let c = r.corners().map(|p| frame.to_px(p));
        for seg in c.windows(2) {
            canvas.line(seg[0], seg[1], LINE_WIDTH, r.color);
        }
    }
    for s in &chart.series {
        draw_series(canvas, s, frame);
    }
    canvas.clip = canvas.full();
    draw_axes(canvas, chart, frame);
    draw_legend(canvas, chart, frame);
}

/// Lines first (split into runs at non-finite points), then markers on top.
fn draw_series(canvas: &mut Canvas, s: &Series, frame: &Frame) {
    let px: Vec<Pt> = s.points.iter().map(|&p| frame.to_px(p)).collect();
    let finite = |p: &Pt| p.0.is_finite() && p.1.is_finite();
    let marker = match s.style {
        Style::Markers(m) | Style::LineAndMarkers(m) => Some(m),
        Style::Line | Style::Dashed => None,
    };
    if !matches!(s.style, Style::Markers(_)) {
        for run in px.split(|p| !finite(p)).filter(|r| !r.is_empty()) {
            match (run.len(), s.style) {
                // A lone point would be invisible as a line; show it as a dot.
                (1, Style::Line | Style::Dashed) => canvas.marker(Marker::Circle, run[0], s.color),
                (_, Style::Dashed) => canvas.dashed(run, LINE_WIDTH, s.color),
                _ => run
                    .windows(2)
                    .for_each(|w| canvas.line(w[0], w[1], LINE_WIDTH, s.color)),
            }
        }
    }
    if let Some(m) = marker {
        px.iter()
            .filter(|p| finite(p))
            .for_each(|&p| canvas.marker(m, p, s.color));
    }
}

/// Light lines at every tick, drawn first so data stays on top.
fn draw_grid(canvas: &mut Canvas, frame: &Frame) {
    let p = frame.plot;
    for (t, _) in &frame.x.ticks {
        let x = frame.to_px((*t, frame.y.lo)).0.round() as i32;
        canvas.fill(x, p.y0 as i32, x + 1, p.y1 as i32, GRID);
    }
    for (t, _) in &frame.y.ticks {
        let y = frame.to_px((frame.x.lo, *t)).1.round() as i32;
        canvas.fill(p.x0 as i32, y, p.x1 as i32, y + 1, GRID);
    }
}

/// Frame, tick marks, tick labels, axis labels and title.
fn draw_axes(canvas: &mut Canvas, chart: &Chart, frame: &Frame) {
    let p = frame.plot;
    let (l, t, r, b) = (p.x0 as i32, p.y0 as i32, p.x1 as i32, p.y1 as i32);
    canvas.fill(l - 1, t - 1, r + 1, t, FRAME);
    canvas.fill(l - 1, b, r + 1, b + 1, FRAME);
    canvas.fill(l - 1, t - 1, l, b + 1, FRAME);
    canvas.fill(r, t - 1, r + 1, b + 1, FRAME);
    let (th, cap) = (text_height(TEXT_SCALE), 7 * TEXT_SCALE);
    let to_x = |v: f64| frame.to_px((v, frame.y.lo)).0.round() as i32;
    let xs: Vec<i32> = frame.x.ticks.iter().map(|(v, _)| to_x(*v)).collect();
    let stride = label_stride(&xs, frame.x.label_width() + 12);
    for (i, ((_, s), &x)) in frame.x.ticks.iter().zip(&xs).enumerate() {
        canvas.fill(x, b, x + 1, b + 5, FRAME);
        if i % stride == 0 {
            label(canvas, x - text_width(s, TEXT_SCALE) / 2, b + 8, s);
        }
    }
    let to_y = |v: f64| frame.to_px((frame.x.lo, v)).1.round() as i32;
    let ys: Vec<i32> = frame.y.ticks.iter().map(|(v, _)| to_y(*v)).collect();
    let stride = label_stride(&ys, cap + 6);
    for (i, ((_, s), &y)) in frame.y.ticks.iter().zip(&ys).enumerate() {
        canvas.fill(l - 5, y, l, y + 1, FRAME);
        if i % stride == 0 {
            label(canvas, l - 8 - text_width(s, TEXT_SCALE), y - cap / 2, s);
        }
    }
    let cx = (l + r) / 2;
    let xw = text_width(&chart.x_label, TEXT_SCALE);
    label(canvas, cx - xw / 2, b + 8 + th + 6, &chart.x_label);
    let (yw, yc) = (text_width(&chart.y_label, TEXT_SCALE), (t + b) / 2);
    canvas.text(PAD, yc + yw / 2, &chart.y_label, TEXT_SCALE, INK, true);
    let tw = text_width(&chart.title, TEXT_SCALE);
    let tx = (cx - tw / 2).clamp(PAD, (canvas.w - tw - PAD).max(PAD));
    // Faux bold: the same text twice, one pixel apart, sets the title apart cheaply.
    for dx in 0..2 {
        canvas.text(tx + dx, PAD, &chart.title, TEXT_SCALE, [0, 0, 0], false);
    }
}

/// Horizontal text in the standard size and colour.
fn label(canvas: &mut Canvas, x: i32, y: i32, s: &str) {
    canvas.text(x, y, s, TEXT_SCALE, INK, false);
}

/// Every how many ticks to print a label so that neighbours stay `need` pixels
/// apart; keeps small images readable when the ticks are dense.
fn label_stride(positions: &[i32], need: i32) -> usize {
    let gap = match positions {
        [a, b, ..] => (b - a).abs().max(1),
        _ => return 1,
    };
    (need / gap + i32::from(need % gap != 0)).max(1) as usize
}

/// Legend box listing each labelled series, placed where it hides the least ink.
fn draw_legend(canvas: &mut Canvas, chart: &Chart, frame: &Frame) {
    let entries: Vec<&Series> = chart
        .series
        .iter()
        .filter(|s| !s.label.is_empty())
        .collect();
    if entries.is_empty() {
        return;
    }
    let (th, sample) = (text_height(TEXT_SCALE), 36);
    let row = th + 4;
    let label_w = entries
        .iter()
        .map(|s| text_width(&s.label, TEXT_SCALE))
        .max()
        .unwrap_or(0);
    let (w, h) = (sample + label_w + 3 * 8, row * entries.len() as i32 + 8);
    let spot = ink_map(chart, frame).best_spot(f64::from(w), f64::from(h), 8.0);
    let (x, y) = spot.unwrap_or((frame.plot.x1 - f64::from(w) - 8.0, frame.plot.y0 + 8.0));
    let (x, y) = (x.round() as i32, y.round() as i32);
    canvas.fill(x, y, x + w, y + h, [190, 190, 190]);
    canvas.fill(x + 1, y + 1, x + w - 1, y + h - 1, WHITE);
    for (i, s) in entries.iter().enumerate() {
        let ty = y + 5 + row * i as i32;
        let mid = f64::from(ty + 7 * TEXT_SCALE / 2);
        let (a, b) = ((f64::from(x + 8), mid), (f64::from(x + 8 + sample), mid));
        match s.style {
            Style::Line | Style::LineAndMarkers(_) => canvas.line(a, b, LINE_WIDTH, s.color),
            Style::Dashed => canvas.dashed(&[a, b], LINE_WIDTH, s.color),
            Style::Markers(_) => {}
        }
        if let Style::Markers(m) | Style::LineAndMarkers(m) = s.style {
            canvas.marker(m, ((a.0 + b.0) / 2.0, mid), s.color);
        }
        label(canvas, x + 16 + sample, ty, &s.label);
    }
}

/// Where the plot already shows series points, lines and rectangle outlines.
fn ink_map(chart: &Chart, frame: &Frame) -> Occupancy {
    let mut ink = Occupancy::new(frame.plot);
    for s in &chart.series {
        let px: Vec<Pt> = s.points.iter().map(|&p| frame.to_px(p)).collect();
        px.iter().for_each(|&p| ink.mark(p));
        if !matches!(s.style, Style::Markers(_)) {
            px.windows(2).for_each(|w| ink.mark_segment(w[0], w[1]));
        }
    }
    for r in &chart.rects {
        r.corners()
            .windows(2)
            .for_each(|w| ink.mark_segment(frame.to_px(w[0]), frame.to_px(w[1])));
    }
    ink
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line_chart(points: Vec<(f64, f64)>, style: Style) -> Chart {
        let mut c = Chart::new("t", "x", "y");
        c.series.push(Series::new("s", [200, 0, 0], style, points));
        c
    }

    #[test]
    fn nice_ticks_use_round_steps() {
        assert_eq!(
            nice_ticks(0.0, 10.0),
            (2.0, vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0])
        );
        let (step, ticks) = nice_ticks(-1.3, 1.3);
        assert_eq!(step, 0.5);
        assert_eq!(ticks.len(), 5);
        for (lo, hi) in [
            (0.0, 1.0),
            (-3.7, 12.1),
            (1e-6, 3e-6),
            (0.01, 0.38),
            (-2e5, 7e5),
            (5.0, 5.4),
        ] {
            let (step, ticks) = nice_ticks(lo, hi);
            assert!((4..=8).contains(&ticks.len()), "{lo}..{hi}: {ticks:?}");
            let mantissa = step / 10f64.powf(step.log10().floor());
            assert!(
                [1.0, 2.0, 5.0].iter().any(|m| (m - mantissa).abs() < 1e-9),
                "{step}"
            );
            assert!(ticks.iter().all(|t| (lo..=hi).contains(t)));
        }
        assert_eq!(nice_ticks(2.0, 2.0).1, vec![2.0]);
        assert!(nice_ticks(f64::NAN, 1.0).1.is_empty());
    }

    #[test]
    fn tick_labels_have_consistent_precision() {
        assert_eq!(format_tick(0.1 + 0.2, 0.1), "0.3");
        assert_eq!(format_tick(-1e-17, 0.5), "0.0");
        assert_eq!(format_tick(20.0, 5.0), "20");
        assert_eq!(format_tick(0.05, 0.05), "0.05");
    }

    #[test]
    fn data_maps_onto_plot_area() {
        let mut c = line_chart(vec![], Style::Line);
        (c.x_range, c.y_range) = (Some((0.0, 10.0)), Some((0.0, 5.0)));
        let f = Frame::layout(&c, 900, 560);
        assert_eq!(f.to_px((0.0, 0.0)), (f.plot.x0, f.plot.y1));
        assert_eq!(f.to_px((10.0, 5.0)), (f.plot.x1, f.plot.y0));
    }

    #[test]
    fn equal_aspect_gives_square_units() {
        let mut c = line_chart(vec![(-1.95, -1.3), (1.95, 1.3)], Style::Line);
        c.equal_aspect = true;
        let f = Frame::layout(&c, 900, 560);
        let o = f.to_px((0.0, 0.0));
        let (ex, ey) = (f.to_px((1.0, 0.0)), f.to_px((0.0, 1.0)));
        assert!(((ex.0 - o.0) - (o.1 - ey.1)).abs() < 1e-9);
        assert!(f.x.lo <= -1.95 && f.x.hi >= 1.95 && f.y.lo <= -1.3 && f.y.hi >= 1.3);
    }

    #[test]
    fn red_series_paints_red_pixels_inside_plot() {
        let mut c = line_chart(vec![(0.0, 0.0), (1.0, 1.0)], Style::Line);
        c.series[0].label.clear(); // no legend, so any red must come from the line
        let img = render_rgb(&c);
        let f = Frame::layout(&c, img.width as i32, img.height as i32);
        let p = f.plot;
        let mut red = 0;
        for (i, px) in img.pixels.chunks(3).enumerate() {
            let (x, y) = ((i as u32 % img.width) as f64, (i as u32 / img.width) as f64);
            if px == [200, 0, 0] {
                assert!(p.grow(2.0).contains((x, y)), "red at {x},{y}");
                red += 1;
            }
        }
        assert!(red > 500, "only {red} red pixels");
    }

    #[test]
    fn degenerate_input_does_not_panic() {
        let nan = f64::NAN;
        let cases = [
            vec![],
            vec![(1.0, 1.0)],
            vec![(3.0, 2.0); 5],
            vec![(nan, nan), (f64::INFINITY, 1.0)],
            vec![(0.0, 0.0), (nan, 1.0), (1.0, 1.0), (2.0, 0.0)],
            vec![(-1e308, -1e308), (1e308, 1e308)],
            vec![(0.0, 1e-300), (1e-300, 0.0)],
        ];
        let styles = [Style::Line, Style::Dashed, Style::Markers(Marker::Cross)];
        for (pts, style) in cases
            .iter()
            .flat_map(|p| styles.iter().map(move |s| (p, *s)))
        {
            for ranges in [None, Some((1.0, 1.0)), Some((nan, 0.0)), Some((5.0, -5.0))] {
                for (w, h, eq) in [(900, 560, false), (0, 0, true), (u32::MAX, 10, true)] {
                    let mut c = line_chart(pts.clone(), style);
                    (c.x_range, c.y_range, c.equal_aspect) = (ranges, ranges, eq);
                    (c.width_px, c.height_px) = (w, h);
                    c.title = "é×°±µ\u{1F600}".repeat(40);
                    let img = render_rgb(&c);
                    assert_eq!(img.pixels.len(), (img.width * img.height * 3) as usize);
                }
            }
        }
    }

    #[test]
    fn legend_avoids_data() {
        let plot = Rect {
            x0: 0.0,
            y0: 0.0,
            x1: 400.0,
            y1: 300.0,
        };
        let mut ink = Occupancy::new(plot);
        ink.mark_segment((250.0, 0.0), (400.0, 120.0)); // cuts off the top-right corner
        let (x, y) = ink.best_spot(100.0, 60.0, 8.0).expect("box fits");
        assert!(x < 20.0 && y < 20.0, "expected top left, got {x},{y}");
        assert!(ink.best_spot(500.0, 60.0, 8.0).is_none());
    }

    #[test]
    fn write_png_round_trips() {
        let c = line_chart(
            vec![(0.0, 1.0), (2.0, 3.0)],
            Style::LineAndMarkers(Marker::Circle),
        );
        let path = std::env::temp_dir().join(format!("plot_test_{}.png", std::process::id()));
        write_png(&c, &path).expect("write");
        let file = std::fs::File::open(&path).expect("open");
        let mut reader = png::Decoder::new(std::io::BufReader::new(file))
            .read_info()
            .expect("decode");
        let mut buf = vec![0; reader.output_buffer_size().expect("size")];
        let info = reader.next_frame(&mut buf).expect("frame");
        std::fs::remove_file(&path).expect("cleanup");
        assert_eq!((info.width, info.height), (c.width_px, c.height_px));
        assert_eq!(info.color_type, png::ColorType::Rgb);
        assert_eq!(&buf[..info.buffer_size()], render_rgb(&c).pixels.as_slice());
    }
}

//! Evaluation plots: line, dashed and marker series and rectangle outlines, drawn with
//! plotters and saved as PNG.
//!
//! Text is drawn with the DejaVu Sans font embedded from `lab/assets/fonts` (see the README
//! there), so the images look the same on every machine and need no system fonts. This
//! file holds the chart description and the layout decisions (ranges, equal aspect,
//! where the legend goes); `plot/draw.rs` turns them into plotters calls.

use std::path::Path;
use std::sync::OnceLock;

use plotters::prelude::{BitMapBackend, IntoDrawingArea, SeriesLabelPosition};
use plotters::style::{FontStyle, register_font};

mod clip;
mod draw;

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
/// break the line, so a NaN can separate unrelated segments. An empty label keeps the
/// series out of the legend.
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

    /// The runs of consecutive finite points: the pieces a line style draws.
    fn runs(&self) -> impl Iterator<Item = &[(f64, f64)]> {
        self.points
            .split(|p| !(p.0.is_finite() && p.1.is_finite()))
            .filter(|r| !r.is_empty())
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
    fn corners(&self) -> [(f64, f64); 5] {
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

/// Why a chart could not be drawn or written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("the embedded font cannot be read")]
    Font,
    #[error("cannot draw or write the plot: {0}")]
    Draw(String),
}

/// Smallest image edge; below this the layout has no room for a plot area.
pub const MIN_SIZE: u32 = 240;
/// Largest image edge, so a typo cannot allocate gigabytes.
pub const MAX_SIZE: u32 = 8192;

/// The family name the embedded font is registered under.
const FONT: &str = "sans-serif";
use lab::CHART_FONT_TTF as FONT_TTF;

/// Registers the embedded font with plotters once per process.
fn ensure_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| register_font(FONT, FontStyle::Normal, FONT_TTF).is_ok());
    if ok { Ok(()) } else { Err(PlotError::Font) }
}

/// Renders the chart into memory.
pub fn render_rgb(chart: &Chart) -> Result<RgbImage, PlotError> {
    ensure_font()?;
    let frame = Frame::layout(chart);
    let mut pixels = vec![0; frame.width as usize * frame.height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (frame.width, frame.height))
            .into_drawing_area();
        draw::chart(&root, chart, &frame)?;
        root.present().map_err(|e| PlotError::Draw(e.to_string()))?;
    }
    Ok(RgbImage {
        width: frame.width,
        height: frame.height,
        pixels,
    })
}

/// Renders the chart and writes it to `path`, which must end in `.png`.
pub fn write_png(chart: &Chart, path: &Path) -> Result<(), PlotError> {
    ensure_font()?;
    let frame = Frame::layout(chart);
    let root = BitMapBackend::new(path, (frame.width, frame.height)).into_drawing_area();
    draw::chart(&root, chart, &frame)?;
    root.present().map_err(|e| PlotError::Draw(e.to_string()))
}

/// Space around the chart, pixels.
const MARGIN: u32 = 12;
/// Height of the title band and the room for the axes' tick labels and names, pixels.
const TITLE_PX: u32 = 40;
const X_AREA_PX: u32 = 56;
const Y_AREA_PX: u32 = 76;

/// A rectangle in pixels, `x0 < x1` and `y0 < y1`, y growing downwards.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PixelRect {
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
}

/// Where everything goes: image size, plot area and the axis ranges mapped onto it.
#[derive(Debug, Clone, PartialEq)]
struct Frame {
    width: u32,
    height: u32,
    title_px: u32,
    plot: PixelRect,
    x: (f64, f64),
    y: (f64, f64),
}

impl Frame {
    /// The plot area is what the fixed margins, title band and label areas leave; the
    /// ranges are the explicit or autoscaled ones, equalised if the chart asks for it.
    fn layout(chart: &Chart) -> Frame {
        let width = chart.width_px.clamp(MIN_SIZE, MAX_SIZE);
        let height = chart.height_px.clamp(MIN_SIZE, MAX_SIZE);
        let title_px = if chart.title.is_empty() { 0 } else { TITLE_PX };
        let plot = PixelRect {
            x0: f64::from(MARGIN + Y_AREA_PX),
            y0: f64::from(title_px + MARGIN),
            x1: f64::from(width - 2 * MARGIN),
            y1: f64::from(height - MARGIN - X_AREA_PX),
        };
        let (xb, yb) = data_bounds(chart);
        let (mut x, mut y) = (
            resolve_range(chart.x_range, xb),
            resolve_range(chart.y_range, yb),
        );
        if chart.equal_aspect {
            (x, y) = equalise(x, y, plot);
        }
        Frame {
            width,
            height,
            title_px,
            plot,
            x,
            y,
        }
    }

    /// Where a data point lands, in pixels.
    fn to_px(&self, p: (f64, f64)) -> (f64, f64) {
        let fx = (p.0 - self.x.0) / (self.x.1 - self.x.0);
        let fy = (p.1 - self.y.0) / (self.y.1 - self.y.0);
        (
            self.plot.x0 + fx * (self.plot.x1 - self.plot.x0),
            self.plot.y1 - fy * (self.plot.y1 - self.plot.y0),
        )
    }
}

/// Extent of all finite series points and rectangle corners, per axis.
#[allow(clippy::type_complexity)]
fn data_bounds(chart: &Chart) -> (Option<(f64, f64)>, Option<(f64, f64)>) {
    let rect_pts = chart
        .rects
        .iter()
        .flat_map(|r| [(r.x0, r.y0), (r.x1, r.y1)]);
    let pts = chart
        .series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .chain(rect_pts);
    let grow = |acc: Option<(f64, f64)>, v: f64| match acc {
        None => Some((v, v)),
        Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
    };
    pts.filter(|p| p.0.is_finite() && p.1.is_finite())
        .fold((None, None), |(x, y), p| (grow(x, p.0), grow(y, p.1)))
}

/// Chooses an axis range: the explicit one if usable, else the data plus 5 %
/// padding, widening empty or zero-width ranges so the mapping never divides by 0.
fn resolve_range(explicit: Option<(f64, f64)>, data: Option<(f64, f64)>) -> (f64, f64) {
    let (lo, hi) = match (explicit, data) {
        (Some((a, b)), _) if a.is_finite() && b.is_finite() => return widen(a.min(b), a.max(b)),
        (_, Some((lo, hi))) => widen(lo, hi),
        _ => (0.0, 1.0),
    };
    let pad = (hi - lo) * 0.05;
    (lo - pad, hi + pad)
}

/// Gives a zero-width range some width and caps huge ones, so that the axis ticks
/// stay computable; data beyond the cap is simply off the plot.
fn widen(lo: f64, hi: f64) -> (f64, f64) {
    const LIMIT: f64 = 1e15;
    let (lo, hi) = (lo.clamp(-LIMIT, LIMIT), hi.clamp(-LIMIT, LIMIT));
    if hi - lo > 1e-9 * lo.abs().max(hi.abs()).max(1e-6) && hi > lo {
        return (lo, hi);
    }
    let d = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
    (lo - d, hi + d)
}

/// Widens one range (about its centre) so both axes share one pixels-per-unit scale.
fn equalise(x: (f64, f64), y: (f64, f64), plot: PixelRect) -> ((f64, f64), (f64, f64)) {
    let (pw, ph) = (plot.x1 - plot.x0, plot.y1 - plot.y0);
    let unit = ((x.1 - x.0) / pw).max((y.1 - y.0) / ph);
    if !unit.is_finite() || unit <= 0.0 {
        return (x, y);
    }
    let centred = |r: (f64, f64), px: f64| {
        let (c, half) = ((r.0 + r.1) * 0.5, unit * px * 0.5);
        (c - half, c + half)
    };
    (centred(x, pw), centred(y, ph))
}

/// The plot-area corner where the legend box (about `w`×`h` pixels) covers the least
/// ink: points, line samples every few pixels and rectangle outlines. Ties go to the
/// upper right, then upper left, lower right, lower left.
fn legend_corner(chart: &Chart, frame: &Frame, w: f64, h: f64) -> SeriesLabelPosition {
    let p = frame.plot;
    let boxes = [
        (SeriesLabelPosition::UpperRight, p.x1 - w - 5.0, p.y0 + 5.0),
        (SeriesLabelPosition::UpperLeft, p.x0 + 5.0, p.y0 + 5.0),
        (
            SeriesLabelPosition::LowerRight,
            p.x1 - w - 5.0,
            p.y1 - h - 5.0,
        ),
        (SeriesLabelPosition::LowerLeft, p.x0 + 5.0, p.y1 - h - 5.0),
    ];
    let mut ink = vec![0usize; boxes.len()];
    let mut mark = |q: (f64, f64)| {
        for (k, (_, x, y)) in boxes.iter().enumerate() {
            ink[k] += usize::from((*x..=x + w).contains(&q.0) && (*y..=y + h).contains(&q.1));
        }
    };
    let mut segment = |a: (f64, f64), b: (f64, f64)| {
        let steps = ((b.0 - a.0).hypot(b.1 - a.1) / 4.0)
            .ceil()
            .clamp(1.0, 2000.0) as usize;
        for i in 0..=steps {
            let t = i as f64 / steps as f64;
            mark((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)));
        }
    };
    for s in &chart.series {
        for run in s.runs() {
            let px: Vec<(f64, f64)> = run.iter().map(|&q| frame.to_px(q)).collect();
            match s.style {
                Style::Markers(_) => px.iter().for_each(|&q| segment(q, q)),
                _ => px.windows(2).for_each(|s| segment(s[0], s[1])),
            }
        }
    }
    for r in &chart.rects {
        let c = r.corners().map(|q| frame.to_px(q));
        c.windows(2).for_each(|s| segment(s[0], s[1]));
    }
    let best = (0..boxes.len()).min_by_key(|&k| ink[k]).unwrap_or(0);
    boxes[best].0.clone()
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
    fn data_maps_onto_plot_area() {
        let mut c = line_chart(vec![], Style::Line);
        (c.x_range, c.y_range) = (Some((0.0, 10.0)), Some((0.0, 5.0)));
        let f = Frame::layout(&c);
        assert_eq!(f.to_px((0.0, 0.0)), (f.plot.x0, f.plot.y1));
        assert_eq!(f.to_px((10.0, 5.0)), (f.plot.x1, f.plot.y0));
    }

    #[test]
    fn autoscale_pads_the_data() {
        let c = line_chart(vec![(0.0, 1.0), (10.0, 3.0)], Style::Line);
        let f = Frame::layout(&c);
        assert_eq!(f.x, (-0.5, 10.5));
        assert!((f.y.0 - 0.9).abs() < 1e-12 && (f.y.1 - 3.1).abs() < 1e-12);
        assert_eq!(resolve_range(None, None), (-0.05, 1.05));
        assert_eq!(resolve_range(Some((2.0, 2.0)), None), (1.8, 2.2));
    }

    #[test]
    fn equal_aspect_gives_square_units() {
        let mut c = line_chart(vec![(-1.95, -1.3), (1.95, 1.3)], Style::Line);
        c.equal_aspect = true;
        let f = Frame::layout(&c);
        let o = f.to_px((0.0, 0.0));
        let (ex, ey) = (f.to_px((1.0, 0.0)), f.to_px((0.0, 1.0)));
        assert!(((ex.0 - o.0) - (o.1 - ey.1)).abs() < 1e-9);
        assert!(f.x.0 <= -1.95 && f.x.1 >= 1.95 && f.y.0 <= -1.3 && f.y.1 >= 1.3);
    }

    #[test]
    fn legend_goes_where_the_data_is_not() {
        // A line rising to the upper right leaves the upper left free.
        let c = line_chart(vec![(0.0, 0.0), (1.0, 1.0)], Style::Line);
        let f = Frame::layout(&c);
        let pos = legend_corner(&c, &f, 200.0, 40.0);
        assert!(matches!(pos, SeriesLabelPosition::UpperLeft), "{pos:?}");
        let c = line_chart(vec![(0.0, 1.0), (1.0, 0.0)], Style::Line);
        let pos = legend_corner(&c, &Frame::layout(&c), 200.0, 40.0);
        assert!(matches!(pos, SeriesLabelPosition::UpperRight), "{pos:?}");
    }

    #[test]
    fn red_series_paints_red_pixels_inside_plot() {
        let mut c = line_chart(vec![(0.0, 0.0), (1.0, 1.0)], Style::Line);
        c.series[0].label.clear(); // no legend, so any red must come from the line
        let img = render_rgb(&c).expect("render");
        let p = Frame::layout(&c).plot;
        let mut red = 0;
        for (i, px) in img.pixels.chunks(3).enumerate() {
            let (x, y) = ((i as u32 % img.width) as f64, (i as u32 / img.width) as f64);
            if px == [200, 0, 0] {
                assert!(
                    x >= p.x0 - 2.0 && x <= p.x1 + 2.0 && y >= p.y0 - 2.0 && y <= p.y1 + 2.0,
                    "red at {x},{y}"
                );
                red += 1;
            }
        }
        assert!(red > 500, "only {red} red pixels");
    }

    #[test]
    fn text_is_drawn() {
        // Title, tick labels and axis names: dark pixels in the title band and left of
        // the plot area, where only text goes.
        let mut c = line_chart(vec![(0.0, 0.0), (1.0, 1.0)], Style::Line);
        c.title = "A title in the band above the plot".into();
        let img = render_rgb(&c).expect("render");
        let f = Frame::layout(&c);
        let dark = |x0: u32, y0: u32, x1: u32, y1: u32| {
            (y0..y1)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .filter(|&(x, y)| {
                    let i = 3 * (y * img.width + x) as usize;
                    img.pixels[i..i + 3].iter().all(|&v| v < 120)
                })
                .count()
        };
        assert!(dark(0, 0, img.width, f.title_px) > 20, "no title");
        assert!(dark(0, f.plot.y0 as u32, f.plot.x0 as u32 - 6, f.plot.y1 as u32) > 50);
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
                    let img = render_rgb(&c).expect("render");
                    assert_eq!(img.pixels.len(), (img.width * img.height * 3) as usize);
                }
            }
        }
    }

    #[test]
    fn write_png_round_trips() {
        let c = line_chart(
            vec![(0.0, 1.0), (2.0, 3.0)],
            Style::LineAndMarkers(Marker::Circle),
        );
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("plot.png");
        write_png(&c, &path).expect("write");
        let file = std::fs::File::open(&path).expect("open");
        let mut reader = png::Decoder::new(std::io::BufReader::new(file))
            .read_info()
            .expect("decode");
        let mut buf = vec![0; reader.output_buffer_size().expect("size")];
        let info = reader.next_frame(&mut buf).expect("frame");
        assert_eq!((info.width, info.height), (c.width_px, c.height_px));
        assert_eq!(info.color_type, png::ColorType::Rgb);
        let img = render_rgb(&c).expect("render");
        assert_eq!(&buf[..info.buffer_size()], img.pixels.as_slice());
    }
}

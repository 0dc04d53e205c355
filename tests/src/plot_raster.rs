//! Raster primitives for [`super`]: an RGB canvas with clipping, antialiased lines,
//! markers, dashes, bitmap text, and a coarse occupancy map for legend placement.
//! Kept apart from the chart logic so each file stays readable.

use super::Marker;
use super::font;

/// Width of series lines and outlines, in pixels.
pub(super) const LINE_WIDTH: f64 = 2.0;
const MARKER_RADIUS: f64 = 4.5;
const DASH_ON: f64 = 10.0;
const DASH_OFF: f64 = 6.0;

/// A point, in data or pixel coordinates.
pub(super) type Pt = (f64, f64);

/// A pixel-space rectangle; `x1`, `y1` are exclusive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Rect {
    pub(super) x0: f64,
    pub(super) y0: f64,
    pub(super) x1: f64,
    pub(super) y1: f64,
}

impl Rect {
    pub(super) fn grow(self, d: f64) -> Rect {
        Rect {
            x0: self.x0 - d,
            y0: self.y0 - d,
            x1: self.x1 + d,
            y1: self.y1 + d,
        }
    }
    pub(super) fn contains(&self, p: Pt) -> bool {
        p.0 >= self.x0 && p.0 < self.x1 && p.1 >= self.y0 && p.1 < self.y1
    }
}

/// RGB pixels plus a clip rectangle, so data drawing cannot spill onto the labels.
pub(super) struct Canvas {
    pub(super) w: i32,
    pub(super) h: i32,
    pub(super) px: Vec<u8>,
    pub(super) clip: Rect,
}

impl Canvas {
    /// A white canvas; callers keep `w`, `h` small enough (see `MAX_SIZE`).
    pub(super) fn new(w: i32, h: i32) -> Self {
        let (w, h) = (w.max(1), h.max(1));
        let px = vec![255; w as usize * h as usize * 3];
        let mut canvas = Self {
            w,
            h,
            px,
            clip: Rect {
                x0: 0.0,
                y0: 0.0,
                x1: 0.0,
                y1: 0.0,
            },
        };
        canvas.clip = canvas.full();
        canvas
    }

    /// The whole canvas, to lift clipping after drawing the data.
    pub(super) fn full(&self) -> Rect {
        Rect {
            x0: 0.0,
            y0: 0.0,
            x1: f64::from(self.w),
            y1: f64::from(self.h),
        }
    }

    /// Mixes `c` into pixel (x, y) with coverage `a` in 0..=1; ignores clipped pixels.
    fn blend(&mut self, x: i32, y: i32, c: [u8; 3], a: f64) {
        let (fx, fy) = (f64::from(x), f64::from(y));
        if x < 0 || y < 0 || x >= self.w || y >= self.h || !self.clip.contains((fx, fy)) {
            return;
        }
        let i = ((y * self.w + x) * 3) as usize;
        let a = a.clamp(0.0, 1.0);
        for (k, &ck) in c.iter().enumerate() {
            let old = f64::from(self.px[i + k]);
            self.px[i + k] = (old + (f64::from(ck) - old) * a).round() as u8;
        }
    }

    pub(super) fn fill(&mut self, x0: i32, y0: i32, x1: i32, y1: i32, c: [u8; 3]) {
        for y in y0.max(0)..y1.min(self.h) {
            for x in x0.max(0)..x1.min(self.w) {
                self.blend(x, y, c, 1.0);
            }
        }
    }

    /// Antialiased line of the given width with round caps. Walks the major axis so
    /// the cost is proportional to length × width, not to the bounding box.
    pub(super) fn line(&mut self, a: Pt, b: Pt, width: f64, c: [u8; 3]) {
        let r = width * 0.5;
        let Some((a, b)) = clip_segment(a, b, self.clip.grow(r + 2.0)) else {
            return;
        };
        let steep = (b.1 - a.1).abs() > (b.0 - a.0).abs();
        let swap = |p: Pt| if steep { (p.1, p.0) } else { p };
        let (mut u0, mut u1) = (swap(a), swap(b));
        if u0.0 > u1.0 {
            std::mem::swap(&mut u0, &mut u1);
        }
        let du = u1.0 - u0.0;
        let slope = if du > 1e-9 { (u1.1 - u0.1) / du } else { 0.0 };
        let half = (r + 1.0) * (1.0 + slope * slope).sqrt();
        for u in (u0.0 - r - 1.0).floor() as i32..=(u1.0 + r + 1.0).ceil() as i32 {
            let uc = (f64::from(u) + 0.5).clamp(u0.0, u1.0);
            let vc = u0.1 + slope * (uc - u0.0);
            for v in (vc - half).floor() as i32..=(vc + half).ceil() as i32 {
                let (x, y) = if steep { (v, u) } else { (u, v) };
                let d = dist_to_segment((f64::from(x) + 0.5, f64::from(y) + 0.5), a, b);
                let cov = r + 0.5 - d;
                if cov > 0.0 {
                    self.blend(x, y, c, cov);
                }
            }
        }
    }

    /// Fills a shape given by a signed distance (positive inside, in pixels) around
    /// `centre`, antialiasing its edge; `extent` bounds the shape.
    fn shape(&mut self, centre: Pt, extent: f64, c: [u8; 3], sd: impl Fn(f64, f64) -> f64) {
        if !centre.0.is_finite()
            || !centre.1.is_finite()
            || !self.clip.grow(extent).contains(centre)
        {
            return;
        }
        let range = |v: f64| (v - extent - 1.0).floor() as i32..=(v + extent + 1.0).ceil() as i32;
        for y in range(centre.1) {
            for x in range(centre.0) {
                let d = sd(f64::from(x) + 0.5 - centre.0, f64::from(y) + 0.5 - centre.1);
                if d + 0.5 > 0.0 {
                    self.blend(x, y, c, d + 0.5);
                }
            }
        }
    }

    /// Draws marker `m` centred on pixel position `p`.
    pub(super) fn marker(&mut self, m: Marker, p: Pt, c: [u8; 3]) {
        let r = MARKER_RADIUS;
        match m {
            Marker::Circle => self.shape(p, r, c, |dx, dy| r - dx.hypot(dy)),
            Marker::Square => {
                let s = r * 0.85;
                self.shape(p, r, c, |dx, dy| (s - dx.abs()).min(s - dy.abs()));
            }
            Marker::Diamond => {
                let s = r * 1.25;
                self.shape(p, s, c, |dx, dy| (s - dx.abs() - dy.abs()) / 2f64.sqrt());
            }
            Marker::Cross => {
                let s = r * 0.85;
                self.line((p.0 - s, p.1 - s), (p.0 + s, p.1 + s), LINE_WIDTH, c);
                self.line((p.0 - s, p.1 + s), (p.0 + s, p.1 - s), LINE_WIDTH, c);
            }
        }
    }

    /// Draws a dashed polyline, keeping the dash phase across vertices
    /// so sharp turns do not restart the pattern.
    pub(super) fn dashed(&mut self, pts: &[Pt], width: f64, c: [u8; 3]) {
        let period = DASH_ON + DASH_OFF;
        let mut phase = 0.0;
        for seg in pts.windows(2) {
            let (a, b) = (seg[0], seg[1]);
            let len = (b.0 - a.0).hypot(b.1 - a.1);
            if !len.is_finite() || len > 1e5 {
                self.line(a, b, width, c); // too long to dash sensibly; draw it solid
                continue;
            }
            let mut t = 0.0;
            while t < len {
                let in_dash = phase < DASH_ON;
                let step = if in_dash {
                    DASH_ON - phase
                } else {
                    period - phase
                }
                .min(len - t);
                if in_dash {
                    let at = |s: f64| (a.0 + (b.0 - a.0) * s / len, a.1 + (b.1 - a.1) * s / len);
                    self.line(at(t), at(t + step), width, c);
                }
                t += step;
                phase = (phase + step) % period;
            }
        }
    }

    /// Draws `s` with its top-left corner at (x, y); `up` rotates it 90° anticlockwise
    /// (reading bottom to top, (x, y) then being the bottom-left corner).
    pub(super) fn text(&mut self, x: i32, y: i32, s: &str, scale: i32, c: [u8; 3], up: bool) {
        for_each_text_pixel(s, scale, |tx, ty| {
            let (px, py) = if up {
                (x + ty, y - tx - 1)
            } else {
                (x + tx, y + ty)
            };
            self.blend(px, py, c, 1.0);
        });
    }
}

/// Horizontal extent of a glyph's ink as (first column, width), so text can be
/// proportionally spaced; a blank glyph (space) gets a fixed 3-column gap.
fn glyph_span(g: &[u8; font::ROWS]) -> (i32, i32) {
    let bits = g.iter().fold(0u8, |acc, r| acc | r);
    if bits == 0 {
        return (0, 3);
    }
    let cols = font::COLS as i32;
    let first = (0..cols)
        .find(|c| bits & (1 << (cols - 1 - c)) != 0)
        .unwrap_or(0);
    let last = (0..cols)
        .rev()
        .find(|c| bits & (1 << (cols - 1 - c)) != 0)
        .unwrap_or(0);
    (first, last - first + 1)
}

/// Calls `f(x, y)` for every lit pixel of `s` rendered at `scale`, relative to the
/// text's top-left corner.
fn for_each_text_pixel(s: &str, scale: i32, mut f: impl FnMut(i32, i32)) {
    let cols = font::COLS as i32;
    let mut pen = 0;
    for ch in s.chars() {
        let g = font::glyph(ch);
        let (first, width) = glyph_span(&g);
        for (row, bits) in g.iter().enumerate() {
            for col in first..first + width {
                if bits & (1 << (cols - 1 - col)) != 0 {
                    let (gx, gy) = (pen + (col - first) * scale, row as i32 * scale);
                    for (dx, dy) in (0..scale).flat_map(|dx| (0..scale).map(move |dy| (dx, dy))) {
                        f(gx + dx, gy + dy);
                    }
                }
            }
        }
        pen += (width + 1) * scale;
    }
}

/// Width in pixels of `s` drawn at `scale`, for centring and right-aligning text.
pub(super) fn text_width(s: &str, scale: i32) -> i32 {
    let w: i32 = s
        .chars()
        .map(|c| (glyph_span(&font::glyph(c)).1 + 1) * scale)
        .sum();
    (w - scale).max(0)
}

/// Height of a text line including descenders.
pub(super) fn text_height(scale: i32) -> i32 {
    font::ROWS as i32 * scale
}

/// Liang–Barsky clipping; also rejects non-finite input so later loops stay bounded.
pub(super) fn clip_segment(a: Pt, b: Pt, r: Rect) -> Option<(Pt, Pt)> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    if ![a.0, a.1, dx, dy].iter().all(|v| v.is_finite()) {
        return None;
    }
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a.0 - r.x0),
        (dx, r.x1 - a.0),
        (-dy, a.1 - r.y0),
        (dy, r.y1 - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else if p < 0.0 {
            t0 = t0.max(q / p);
        } else {
            t1 = t1.min(q / p);
        }
    }
    let at = |t: f64| (a.0 + t * dx, a.1 + t * dy);
    (t0 <= t1).then(|| (at(t0), at(t1)))
}

/// Distance from `p` to the segment `a`–`b`; drives the line antialiasing.
fn dist_to_segment(p: Pt, a: Pt, b: Pt) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p.0 - a.0 - t * dx).hypot(p.1 - a.1 - t * dy)
}

/// Cell size of the occupancy map: coarse enough to be cheap, fine enough that a
/// legend can still fit between curves.
const CELL: f64 = 4.0;

/// Which cells of an area (the plot) already carry ink, so the legend can be put
/// where it hides the least data.
pub(super) struct Occupancy {
    area: Rect,
    cols: usize,
    rows: usize,
    marks: Vec<bool>,
}

impl Occupancy {
    pub(super) fn new(area: Rect) -> Self {
        let cells = |len: f64| ((len / CELL).ceil() as usize).clamp(1, 4096);
        let (cols, rows) = (cells(area.x1 - area.x0), cells(area.y1 - area.y0));
        Self {
            area,
            cols,
            rows,
            marks: vec![false; cols * rows],
        }
    }

    /// Marks the cell under `p`; points outside the area are ignored.
    pub(super) fn mark(&mut self, p: Pt) {
        if self.area.contains(p) {
            let c = (((p.0 - self.area.x0) / CELL) as usize).min(self.cols - 1);
            let r = (((p.1 - self.area.y0) / CELL) as usize).min(self.rows - 1);
            self.marks[r * self.cols + c] = true;
        }
    }

    /// Marks the cells along a segment, sampled every half cell.
    pub(super) fn mark_segment(&mut self, a: Pt, b: Pt) {
        let Some((a, b)) = clip_segment(a, b, self.area) else {
            return;
        };
        let n = ((a.0 - b.0).hypot(a.1 - b.1) / (CELL * 0.5))
            .ceil()
            .min(1e5) as usize;
        for i in 0..=n {
            let t = i as f64 / n.max(1) as f64;
            self.mark((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)));
        }
    }

    /// Top-left corner of a `w`×`h` box, kept `inset` pixels inside the area, that
    /// covers the fewest inked cells (counting a margin, so it keeps clear of
    /// lines); ties go to the box nearest a corner, top right first. `None` if the
    /// box does not fit.
    pub(super) fn best_spot(&self, w: f64, h: f64, inset: f64) -> Option<Pt> {
        const MARGIN: usize = 2;
        let (cols, rows) = (self.cols, self.rows);
        // Summed-area table, so the ink under any box costs four lookups.
        let mut sums = vec![0u32; (cols + 1) * (rows + 1)];
        for r in 0..rows {
            for c in 0..cols {
                let here = u32::from(self.marks[r * cols + c]);
                sums[(r + 1) * (cols + 1) + c + 1] =
                    here + sums[r * (cols + 1) + c + 1] + sums[(r + 1) * (cols + 1) + c]
                        - sums[r * (cols + 1) + c];
            }
        }
        let ink = |c0: usize, r0: usize, c1: usize, r1: usize| {
            let at = |c: usize, r: usize| sums[r * (cols + 1) + c];
            at(c1, r1) + at(c0, r0) - at(c0, r1) - at(c1, r0)
        };
        let (bw, bh, ins) = (
            (w / CELL).ceil() as usize,
            (h / CELL).ceil() as usize,
            (inset / CELL).round() as usize,
        );
        let cmax = cols.checked_sub(bw + ins).filter(|&m| m >= ins)?;
        let rmax = rows.checked_sub(bh + ins).filter(|&m| m >= ins)?;
        let mut best: Option<(u64, usize, usize)> = None;
        for r in ins..=rmax {
            for c in ins..=cmax {
                let (c0, r0) = (c.saturating_sub(MARGIN), r.saturating_sub(MARGIN));
                let covered = ink(
                    c0,
                    r0,
                    (c + bw + MARGIN).min(cols),
                    (r + bh + MARGIN).min(rows),
                );
                let (left, right, top, bottom) = (c - ins, cmax - c, r - ins, rmax - r);
                let corner = [right + top, left + top, right + bottom, left + bottom];
                let dist = corner
                    .iter()
                    .enumerate()
                    .map(|(i, d)| d * 4 + i)
                    .min()
                    .unwrap_or(0);
                let score = u64::from(covered) * 1_000_000 + dist as u64;
                if best.is_none_or(|b| score < b.0) {
                    best = Some((score, c, r));
                }
            }
        }
        best.map(|(_, c, r)| {
            (
                self.area.x0 + c as f64 * CELL,
                self.area.y0 + r as f64 * CELL,
            )
        })
    }
}

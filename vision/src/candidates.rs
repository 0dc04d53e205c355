//! The candidate network: a tiny fully convolutional network over the downscaled frame
//! whose output is a heatmap of where balls are, one cell per 8 input pixels, each cell
//! with a ball's logit and the ball's centre and radius.
//!
//! The frame is shrunk by area averaging to at most [`INPUT_WIDTH_PX`] wide (never
//! enlarged), each colour channel less its mean over the frame, over the spread of all
//! values ([`input`]). Layers ([`LAYERS`]): three 3×3 stride-2 convolutions (3→8→16→16)
//! and a 3×3 convolution of dilation 2 (16→16, so a cell sees about 60 input pixels), all
//! with ReLU, then a 1×1 head of four outputs per cell: the logit, the centre's offset from
//! the cell's centre in cells, and ln(radius / cell side). About 12 M multiply-adds at
//! 640×360 (a 320×184 input).
//!
//! The candidates ([`HeatNet::candidates`]) are the cells that are local maxima of the
//! logit over their 3×3 neighbours, most probable first, kept spread over the image: a
//! new peak too near a kept one (within the larger of their radii and one cell) is left
//! out.

use crate::circle::Circle;
use crate::image::RgbImage;
use crate::nn::{Act, Conv, WeightsError, WeightsFile};
use std::collections::BTreeMap;

/// The shipped two-stage detector's weights (the candidate network and the grey checker,
/// safetensors), made by `ball-lab train` (the command and held-out score are in the
/// file's metadata).
pub const SHIPPED_WEIGHTS: &[u8] = include_bytes!("../data/detector.safetensors");

/// The format named in a two-stage detector's weights file.
pub const FORMAT: &str = "ball-detector-v1";

/// The widest input; wider frames are shrunk to it.
pub const INPUT_WIDTH_PX: u32 = 320;

/// Input pixels per output cell.
pub const CELL_PX: usize = 8;

/// Outputs per cell: logit, centre offset x and y (cells), ln(radius / cell).
pub const OUTPUTS: usize = 4;

/// The centre of cell `index` along one axis, input pixels: the centre of its receptive
/// field (three stride-2 layers of 3×3 kernels padded by one put cell `i` over input pixel
/// `8 i`, whose centre is half a pixel on).
pub fn cell_centre_px(index: usize) -> f64 {
    (index * CELL_PX) as f64 + 0.5
}

/// The cell whose centre is nearest to `x_px` (input pixels) along an axis of `cells`.
pub fn nearest_cell(x_px: f64, cells: usize) -> usize {
    (((x_px - 0.5) / CELL_PX as f64).round().max(0.0) as usize).min(cells.saturating_sub(1))
}

/// One 3×3 convolution of the candidate network, with ReLU, padded to keep the side at
/// stride 1 (tensors `heat.{name}.weight` `[out, in, 3, 3]` and `heat.{name}.bias`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layer {
    pub name: &'static str,
    pub cin: usize,
    pub cout: usize,
    pub stride: usize,
    pub dilation: usize,
}

/// The layers before the head, in order.
pub const LAYERS: [Layer; 4] = [
    Layer {
        name: "c1",
        cin: 3,
        cout: 8,
        stride: 2,
        dilation: 1,
    },
    Layer {
        name: "c2",
        cin: 8,
        cout: 16,
        stride: 2,
        dilation: 1,
    },
    Layer {
        name: "c3",
        cin: 16,
        cout: 16,
        stride: 2,
        dilation: 1,
    },
    Layer {
        name: "c4",
        cin: 16,
        cout: 16,
        stride: 1,
        dilation: 2,
    },
];

/// Channels into the head.
pub const HEAD_IN: usize = 16;

/// How the frame is shrunk for the network.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InputGeometry {
    /// Input pixels per frame pixel (≤ 1).
    pub scale: f64,
    /// The shrunk frame's size, before padding.
    pub width_px: usize,
    pub height_px: usize,
    /// The padded input's size (multiples of [`CELL_PX`]).
    pub padded_width_px: usize,
    pub padded_height_px: usize,
}

impl InputGeometry {
    /// The geometry for a frame of `width`×`height` at `scale` input pixels per frame
    /// pixel.
    pub fn with_scale(width: u32, height: u32, scale: f64) -> Self {
        let w = ((f64::from(width) * scale).round() as usize).max(1);
        let h = ((f64::from(height) * scale).round() as usize).max(1);
        InputGeometry {
            scale,
            width_px: w,
            height_px: h,
            padded_width_px: w.div_ceil(CELL_PX) * CELL_PX,
            padded_height_px: h.div_ceil(CELL_PX) * CELL_PX,
        }
    }

    /// The geometry the network was trained at for a frame: at most [`INPUT_WIDTH_PX`]
    /// wide.
    pub fn for_frame(width: u32, height: u32) -> Self {
        Self::for_frame_at(width, height, INPUT_WIDTH_PX)
    }

    /// The geometry for a frame shrunk to at most `input_width_px` wide (never enlarged).
    pub fn for_frame_at(width: u32, height: u32, input_width_px: u32) -> Self {
        let scale = (f64::from(input_width_px.max(1)) / f64::from(width.max(1))).min(1.0);
        Self::with_scale(width, height, scale)
    }
}

/// The frame shrunk by area averaging to the geometry's size: RGB values 0..255, rows of
/// pixels with the channels innermost.
pub fn shrink(image: &RgbImage, g: &InputGeometry) -> Vec<f32> {
    let (w, h) = (g.width_px, g.height_px);
    let (iw, ih) = (image.width() as usize, image.height() as usize);
    let data = image.data();
    let mut out = vec![0f32; w * h * 3];
    // Each output pixel averages the frame's pixels whose centres fall in its footprint.
    let bounds = |i: usize, n_out: usize, n_in: usize| {
        let a = (i * n_in) / n_out;
        let b = (((i + 1) * n_in) / n_out).max(a + 1).min(n_in);
        (a, b)
    };
    if 2 * w == iw && 2 * h == ih {
        halve_into(data, iw, &mut out);
        return out;
    }
    let xs: Vec<(usize, usize)> = (0..w).map(|x| bounds(x, w, iw)).collect();
    for y in 0..h {
        let (y0, y1) = bounds(y, h, ih);
        for (x, &(x0, x1)) in xs.iter().enumerate() {
            let mut acc = [0f32; 3];
            for sy in y0..y1 {
                let row = &data[(sy * iw + x0) * 3..(sy * iw + x1) * 3];
                for px in row.chunks_exact(3) {
                    acc[0] += f32::from(px[0]);
                    acc[1] += f32::from(px[1]);
                    acc[2] += f32::from(px[2]);
                }
            }
            let n = ((y1 - y0) * (x1 - x0)) as f32;
            out[(y * w + x) * 3..][..3].copy_from_slice(&acc.map(|v| v / n));
        }
    }
    out
}

/// The frame halved (each output pixel the mean of a 2×2 block, as the general path of
/// [`shrink`] computes it), row pair by row pair.
fn halve_into(data: &[u8], iw: usize, out: &mut [f32]) {
    let w = iw / 2;
    let stride = 3 * iw;
    for (y, out_row) in out.chunks_exact_mut(3 * w).enumerate() {
        let (r0, r1) = (
            &data[2 * y * stride..][..stride],
            &data[(2 * y + 1) * stride..][..stride],
        );
        for ((o, a), b) in out_row
            .chunks_exact_mut(3)
            .zip(r0.chunks_exact(6))
            .zip(r1.chunks_exact(6))
        {
            for k in 0..3 {
                let s =
                    u16::from(a[k]) + u16::from(a[k + 3]) + u16::from(b[k]) + u16::from(b[k + 3]);
                o[k] = f32::from(s) * 0.25;
            }
        }
    }
}

/// The network's input from a shrunk frame (values 0..255, `width`×`height`): each channel
/// less its mean, over the spread of all values (plus a floor), padded with zeros to the
/// padded size. Training uses the same function.
pub fn normalise(shrunk: &[f32], g: &InputGeometry) -> Act {
    let (w, h) = (g.width_px, g.height_px);
    let n = (w * h) as f32;
    let mut sum = [0f32; 3];
    for px in shrunk.chunks_exact(3) {
        for k in 0..3 {
            sum[k] += px[k];
        }
    }
    let mean = sum.map(|m| m / n);
    let mut var = 0f32;
    for px in shrunk.chunks_exact(3) {
        for k in 0..3 {
            let d = px[k] - mean[k];
            var += d * d;
        }
    }
    // In units of 0..1: the spread of the values over 255, plus the floor.
    let scale = 1.0 / ((var / (3.0 * n)).sqrt() / 255.0 + 0.03) / 255.0;
    let mut act = Act::zeros(1, g.padded_height_px, g.padded_width_px, 3);
    for (src, dst) in shrunk
        .chunks_exact(3 * w)
        .zip(act.data.chunks_exact_mut(3 * g.padded_width_px))
    {
        for (s, d) in src.chunks_exact(3).zip(dst.chunks_exact_mut(3)) {
            for k in 0..3 {
                d[k] = (s[k] - mean[k]) * scale;
            }
        }
    }
    act
}

/// The network's input for a frame, and the geometry it was made with.
pub fn input(image: &RgbImage) -> (Act, InputGeometry) {
    input_at(image, INPUT_WIDTH_PX)
}

/// The network's input for a frame shrunk to at most `input_width_px` wide.
pub fn input_at(image: &RgbImage, input_width_px: u32) -> (Act, InputGeometry) {
    let g = InputGeometry::for_frame_at(image.width(), image.height(), input_width_px);
    (normalise(&shrink(image, &g), &g), g)
}

/// A cell's outputs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    pub logit: f32,
    pub offset: [f32; 2],
    pub log_radius: f32,
}

/// The network's output over a frame: `rows`×`cols` cells.
#[derive(Debug, Clone, PartialEq)]
pub struct Heatmap {
    pub rows: usize,
    pub cols: usize,
    /// `[row][col][OUTPUTS]`.
    pub values: Vec<f32>,
    pub geometry: InputGeometry,
}

impl Heatmap {
    pub fn cell(&self, row: usize, col: usize) -> Cell {
        let v = &self.values[(row * self.cols + col) * OUTPUTS..][..OUTPUTS];
        Cell {
            logit: v[0],
            offset: [v[1], v[2]],
            log_radius: v[3],
        }
    }

    /// A cell's ball as a circle in the frame's pixels.
    pub fn circle(&self, row: usize, col: usize) -> Circle {
        let c = self.cell(row, col);
        let cell = CELL_PX as f64;
        let s = self.geometry.scale;
        let ox = f64::from(c.offset[0]).clamp(-1.5, 1.5);
        let oy = f64::from(c.offset[1]).clamp(-1.5, 1.5);
        let lr = f64::from(c.log_radius).clamp(-3.0, 3.5);
        Circle {
            center_px: [
                (cell_centre_px(col) + ox * cell) / s,
                (cell_centre_px(row) + oy * cell) / s,
            ],
            radius_px: (lr.exp() * cell / s).max(1.0),
            score: 1.0 / (1.0 + (-f64::from(c.logit)).exp()),
        }
    }
}

/// How candidates are read off the heatmap.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PeakConfig {
    /// At most this many candidates from the network.
    pub max_candidates: usize,
    /// A peak below this probability is not a candidate.
    pub min_probability: f64,
    /// The frame is shrunk to at most this wide for the network (the network was trained
    /// at 320 and at 0.6–1.5 times that scale; narrower is faster, and loses far balls).
    pub input_width_px: u32,
}

impl Default for PeakConfig {
    fn default() -> Self {
        PeakConfig {
            max_candidates: 8,
            min_probability: 0.005,
            input_width_px: INPUT_WIDTH_PX,
        }
    }
}

impl PeakConfig {
    pub fn check(&self) -> Result<(), String> {
        if !(0.0..=1.0).contains(&self.min_probability) {
            return Err(format!(
                "min_probability {} is outside [0, 1]",
                self.min_probability
            ));
        }
        if !(64..=1280).contains(&self.input_width_px) {
            return Err(format!(
                "input_width_px {} is outside 64..=1280",
                self.input_width_px
            ));
        }
        Ok(())
    }
}

/// The candidate network, ready to run.
#[derive(Debug, Clone, PartialEq)]
pub struct HeatNet {
    layers: Vec<Conv>,
    head: Conv,
    metadata: BTreeMap<String, String>,
}

impl HeatNet {
    /// The candidate network of a detector's weights file.
    pub fn from_safetensors(bytes: &[u8]) -> Result<Self, WeightsError> {
        let file = WeightsFile::read(bytes, FORMAT)?;
        let layers = LAYERS
            .iter()
            .map(|l| {
                file.conv_dilated(
                    &format!("heat.{}", l.name),
                    l.cin,
                    l.cout,
                    l.stride,
                    l.dilation,
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        let head = file.conv("heat.head", HEAD_IN, OUTPUTS, 1, 1, 0)?;
        Ok(HeatNet {
            layers,
            head,
            metadata: file.metadata().clone(),
        })
    }

    pub fn metadata(&self) -> &BTreeMap<String, String> {
        &self.metadata
    }

    /// Multiply-adds for a frame of this size at the trained input width.
    pub fn multiply_adds(&self, width: u32, height: u32) -> usize {
        self.multiply_adds_at(width, height, INPUT_WIDTH_PX)
    }

    /// Multiply-adds for a frame of this size shrunk to at most `input_width_px` wide.
    pub fn multiply_adds_at(&self, width: u32, height: u32, input_width_px: u32) -> usize {
        let g = InputGeometry::for_frame_at(width, height, input_width_px);
        let (mut h, mut w) = (g.padded_height_px, g.padded_width_px);
        let mut total = 0;
        for l in &self.layers {
            total += l.multiply_adds(h, w);
            (h, w) = l.out_size(h, w);
        }
        total + self.head.multiply_adds(h, w)
    }

    /// The heatmap of an input made by [`input`] or [`normalise`].
    pub fn forward(&self, x: &Act, geometry: InputGeometry) -> Heatmap {
        let mut scratch = Vec::new();
        let mut a = self.layers[0].forward(x, true, &mut scratch);
        for l in &self.layers[1..] {
            a = l.forward(&a, true, &mut scratch);
        }
        let out = self.head.forward(&a, false, &mut scratch);
        Heatmap {
            rows: out.h,
            cols: out.w,
            values: out.data,
            geometry,
        }
    }

    /// The heatmap of a frame.
    pub fn heatmap(&self, image: &RgbImage) -> Heatmap {
        let (x, g) = input(image);
        self.forward(&x, g)
    }

    /// The frame's candidates: see the module's documentation.
    pub fn candidates(&self, image: &RgbImage, cfg: &PeakConfig) -> Vec<Circle> {
        let (x, g) = input_at(image, cfg.input_width_px);
        peaks(&self.forward(&x, g), cfg)
    }

    /// The candidates of a frame already shrunk by [`shrink`] to `g` (so that the caller
    /// can reuse the shrunk frame).
    pub fn candidates_from_shrunk(
        &self,
        shrunk: &[f32],
        g: InputGeometry,
        cfg: &PeakConfig,
    ) -> Vec<Circle> {
        peaks(&self.forward(&normalise(shrunk, &g), g), cfg)
    }
}

/// The heatmap's peaks as circles, most probable first, spread over the image.
pub fn peaks(map: &Heatmap, cfg: &PeakConfig) -> Vec<Circle> {
    let min_logit = if cfg.min_probability <= 0.0 {
        f32::NEG_INFINITY
    } else if cfg.min_probability >= 1.0 {
        f32::INFINITY
    } else {
        (cfg.min_probability / (1.0 - cfg.min_probability)).ln() as f32
    };
    let (rows, cols) = (map.rows, map.cols);
    let mut found: Vec<(f32, usize, usize)> = Vec::new();
    for r in 0..rows {
        for c in 0..cols {
            let l = map.cell(r, c).logit;
            if l < min_logit {
                continue;
            }
            let mut peak = true;
            'n: for dr in -1i64..=1 {
                for dc in -1i64..=1 {
                    let (nr, nc) = (r as i64 + dr, c as i64 + dc);
                    if (dr, dc) == (0, 0) || nr < 0 || nc < 0 {
                        continue;
                    }
                    let (nr, nc) = (nr as usize, nc as usize);
                    if nr >= rows || nc >= cols {
                        continue;
                    }
                    let n = map.cell(nr, nc).logit;
                    // Ties go to the first cell in reading order.
                    if n > l || (n == l && (nr, nc) < (r, c)) {
                        peak = false;
                        break 'n;
                    }
                }
            }
            if peak {
                found.push((l, r, c));
            }
        }
    }
    found.sort_by(|a, b| b.0.total_cmp(&a.0));
    let cell_px = CELL_PX as f64 / map.geometry.scale;
    let mut kept: Vec<Circle> = Vec::new();
    for (_, r, c) in found {
        if kept.len() >= cfg.max_candidates {
            break;
        }
        let circle = map.circle(r, c);
        let near = kept.iter().any(|k| {
            let d =
                (k.center_px[0] - circle.center_px[0]).hypot(k.center_px[1] - circle.center_px[1]);
            d < k.radius_px.max(circle.radius_px).max(cell_px)
        });
        if !near {
            kept.push(circle);
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn frames_shrink_to_the_input_width_and_pad_to_cells() {
        let g = InputGeometry::for_frame(640, 360);
        assert_eq!((g.width_px, g.height_px), (320, 180));
        assert_eq!((g.padded_width_px, g.padded_height_px), (320, 184));
        let small = InputGeometry::for_frame(224, 224);
        assert_eq!(small.scale, 1.0);
        assert_eq!(small.padded_width_px, 224);
    }

    #[test]
    fn a_point_belongs_to_the_cell_whose_centre_is_nearest() {
        assert_eq!(cell_centre_px(2), 16.5);
        assert_eq!(nearest_cell(16.5, 10), 2);
        assert_eq!(nearest_cell(20.4, 10), 2);
        assert_eq!(nearest_cell(20.6, 10), 3);
        assert_eq!(nearest_cell(-3.0, 10), 0);
        assert_eq!(nearest_cell(500.0, 10), 9);
    }

    #[test]
    fn shrinking_averages_areas() {
        let mut image = RgbImage::filled(4, 2, [0, 0, 0]).unwrap();
        image.set_pixel(0, 0, [200, 100, 40]);
        let g = InputGeometry::with_scale(4, 2, 0.5);
        let s = shrink(&image, &g);
        assert_eq!(s.len(), 2 * 3);
        assert_eq!(&s[..3], &[50.0, 25.0, 10.0]);
        assert_eq!(&s[3..], &[0.0, 0.0, 0.0]);
    }

    fn map(logits: &[f32], rows: usize, cols: usize) -> Heatmap {
        Heatmap {
            rows,
            cols,
            values: logits.iter().flat_map(|&l| [l, 0.0, 0.0, 0.0]).collect(),
            geometry: InputGeometry::with_scale(cols as u32 * 8, rows as u32 * 8, 1.0),
        }
    }

    #[test]
    fn peaks_are_local_maxima_most_probable_first() {
        #[rustfmt::skip]
        let logits = [
            -9.0, -9.0, -9.0, -9.0, -9.0,
            -9.0,  2.0,  1.0, -9.0, -9.0,
            -9.0, -9.0, -9.0, -9.0,  4.0,
        ];
        let m = map(&logits, 3, 5);
        let p = peaks(&m, &PeakConfig::default());
        assert_eq!(p.len(), 2, "{p:?}");
        // The strongest (row 2, col 4) first, at its cell's centre.
        assert_eq!(p[0].center_px, [32.5, 16.5]);
        assert_eq!(p[1].center_px, [8.5, 8.5]);
        assert!(p[0].score > p[1].score);
        let one = peaks(
            &m,
            &PeakConfig {
                max_candidates: 1,
                ..PeakConfig::default()
            },
        );
        assert_eq!(one.len(), 1);
        let none = peaks(
            &m,
            &PeakConfig {
                min_probability: 0.99,
                ..PeakConfig::default()
            },
        );
        assert!(none.is_empty());
    }
}

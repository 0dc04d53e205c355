//! The forward pass of the detector's small networks, written for a CPU.
//!
//! Activations are batches of images, rows of pixels with the channels innermost
//! ([`Act`], NHWC). A spatial convolution of 8 or 16 outputs (every layer of the shipped
//! networks) is computed directly: each output pixel's sums held together while the
//! kernel's taps are read in place, which moves far less memory than a copy and a packed
//! product on tensors this small. Any other convolution is an im2col copy and one matrix
//! product for the whole batch (dilated kernels too); a 1×1 convolution or a dense layer
//! is the matrix product alone; the products run through nalgebra's general matrix multiply, which hands
//! dynamically sized f32 products to the `matrixmultiply` crate's cache-blocked, vectorised
//! kernels (AVX/FMA on x86-64, NEON on the Raspberry Pi's ARM, picked at run time). Pooling
//! is a direct loop over contiguous channels.
//!
//! Weights are kept in the order the loops read them: a convolution's `[ky][kx][in][out]`,
//! a dense layer's `[in][out]`. The training crate's layouts (`[out][in][ky][kx]`,
//! `[out][in]`) are converted when a weights file is read ([`Conv::from_oihw`],
//! [`Conv::dense_from_oi`]), and every network's file is checked tensor by tensor
//! ([`WeightsFile`]).

use nalgebra::{DMatrixView, DMatrixViewMut};
use std::collections::BTreeMap;
use thiserror::Error;

/// A batch of activations, `[n][h][w][c]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Act {
    pub n: usize,
    pub h: usize,
    pub w: usize,
    pub c: usize,
    pub data: Vec<f32>,
}

impl Act {
    /// A batch of zeros.
    pub fn zeros(n: usize, h: usize, w: usize, c: usize) -> Self {
        Act {
            n,
            h,
            w,
            c,
            data: vec![0.0; n * h * w * c],
        }
    }

    /// The values of one pixel of one image of the batch.
    pub fn pixel(&self, i: usize, y: usize, x: usize) -> &[f32] {
        &self.data[((i * self.h + y) * self.w + x) * self.c..][..self.c]
    }
}

/// `out[rows][cout] += x[rows][k] · w[k][cout]`, all row-major.
fn gemm_acc(x: &[f32], rows: usize, k: usize, w: &[f32], cout: usize, out: &mut [f32]) {
    // Row-major data read as column-major is the transpose: outᵀ = wᵀ · xᵀ.
    let xt = DMatrixView::from_slice(&x[..rows * k], k, rows);
    let wt = DMatrixView::from_slice(&w[..k * cout], cout, k);
    let mut yt = DMatrixViewMut::from_slice(&mut out[..rows * cout], cout, rows);
    yt.gemm(1.0, &wt, &xt, 1.0);
}

/// Every row of `out` set to `bias`.
fn fill_bias(out: &mut [f32], bias: &[f32]) {
    for row in out.chunks_exact_mut(bias.len()) {
        row.copy_from_slice(bias);
    }
}

fn relu_in_place(v: &mut [f32]) {
    for a in v {
        *a = a.max(0.0);
    }
}

/// Output side of a convolution or pooling window.
fn out_side(side: usize, k: usize, stride: usize, pad: usize, dilation: usize) -> usize {
    let span = dilation * (k - 1) + 1;
    (side + 2 * pad).saturating_sub(span) / stride + 1
}

/// A convolution of square kernels (a dense layer is a 1×1 one over a 1×1 image).
#[derive(Debug, Clone, PartialEq)]
pub struct Conv {
    pub k: usize,
    pub stride: usize,
    pub pad: usize,
    /// Spacing of the kernel's taps (1: a plain convolution).
    pub dilation: usize,
    pub cin: usize,
    pub cout: usize,
    /// `[ky][kx][in][out]`.
    pub weights: Vec<f32>,
    pub bias: Vec<f32>,
}

impl Conv {
    /// A convolution from the training crate's `[out][in][ky][kx]` weights.
    pub fn from_oihw(
        w: &[f32],
        bias: Vec<f32>,
        cin: usize,
        k: usize,
        stride: usize,
        pad: usize,
    ) -> Self {
        let cout = bias.len();
        let mut weights = vec![0f32; cout * cin * k * k];
        for o in 0..cout {
            for i in 0..cin {
                for ky in 0..k {
                    for kx in 0..k {
                        weights[((ky * k + kx) * cin + i) * cout + o] =
                            w[((o * cin + i) * k + ky) * k + kx];
                    }
                }
            }
        }
        Conv {
            k,
            stride,
            pad,
            dilation: 1,
            cin,
            cout,
            weights,
            bias,
        }
    }

    /// The same convolution with its taps `dilation` apart.
    pub fn dilated(self, dilation: usize) -> Self {
        Conv { dilation, ..self }
    }

    /// A dense layer from the training crate's `[out][in]` weights, whose inputs were
    /// flattened channel-major from `[channels][cells]` (set `cells` to 1 for a plain
    /// vector); the forward pass here flattens cell-major with the channels innermost.
    pub fn dense_from_oi(w: &[f32], bias: Vec<f32>, channels: usize, cells: usize) -> Self {
        let cout = bias.len();
        let cin = channels * cells;
        let mut weights = vec![0f32; cout * cin];
        for o in 0..cout {
            for c in 0..channels {
                for cell in 0..cells {
                    weights[(cell * channels + c) * cout + o] = w[o * cin + c * cells + cell];
                }
            }
        }
        Conv {
            k: 1,
            stride: 1,
            pad: 0,
            dilation: 1,
            cin,
            cout,
            weights,
            bias,
        }
    }

    /// Multiply-adds for an input of `h`×`w` pixels.
    pub fn multiply_adds(&self, h: usize, w: usize) -> usize {
        let (oh, ow) = self.out_size(h, w);
        oh * ow * self.k * self.k * self.cin * self.cout
    }

    /// The output's height and width for an input of `h`×`w` pixels.
    pub fn out_size(&self, h: usize, w: usize) -> (usize, usize) {
        (
            out_side(h, self.k, self.stride, self.pad, self.dilation),
            out_side(w, self.k, self.stride, self.pad, self.dilation),
        )
    }

    /// The convolution of a batch; `scratch` holds the im2col copy between calls.
    pub fn forward(&self, x: &Act, relu: bool, scratch: &mut Vec<f32>) -> Act {
        debug_assert_eq!(x.c, self.cin);
        let (k, s, p, d) = (self.k, self.stride, self.pad, self.dilation);
        let (oh, ow) = self.out_size(x.h, x.w);
        let rows = x.n * oh * ow;
        let mut out = Act {
            n: x.n,
            h: oh,
            w: ow,
            c: self.cout,
            data: vec![0.0; rows * self.cout],
        };
        // Spatial kernels of 8 or 16 outputs: direct, no copies.
        let direct = k > 1 || s > 1 || p > 0 || d > 1;
        match self.cout {
            8 if direct => return self.direct::<8>(x, relu, out),
            16 if direct => return self.direct::<16>(x, relu, out),
            _ => {}
        }
        fill_bias(&mut out.data, &self.bias);
        if k == 1 && s == 1 && p == 0 && d == 1 {
            gemm_acc(
                &x.data,
                rows,
                self.cin,
                &self.weights,
                self.cout,
                &mut out.data,
            );
        } else {
            let kk = k * k * self.cin;
            scratch.clear();
            scratch.resize(rows * kk, 0.0);
            for i in 0..x.n {
                for oy in 0..oh {
                    for ox in 0..ow {
                        let row = &mut scratch[((i * oh + oy) * ow + ox) * kk..][..kk];
                        for ky in 0..k {
                            let Some(iy) = (oy * s + ky * d).checked_sub(p).filter(|&y| y < x.h)
                            else {
                                continue;
                            };
                            // With no dilation, a row of the kernel inside the image
                            // reads k neighbouring pixels: one copy.
                            let x0 = ox * s;
                            if d == 1 && x0 >= p && x0 + k - p <= x.w {
                                let start = ((i * x.h + iy) * x.w + x0 - p) * self.cin;
                                let n = k * self.cin;
                                row[ky * n..][..n].copy_from_slice(&x.data[start..][..n]);
                                continue;
                            }
                            for kx in 0..k {
                                let Some(ix) =
                                    (ox * s + kx * d).checked_sub(p).filter(|&v| v < x.w)
                                else {
                                    continue;
                                };
                                copy_channels(
                                    &mut row[(ky * k + kx) * self.cin..][..self.cin],
                                    x.pixel(i, iy, ix),
                                );
                            }
                        }
                    }
                }
            }
            gemm_acc(scratch, rows, kk, &self.weights, self.cout, &mut out.data);
        }
        if relu {
            relu_in_place(&mut out.data);
        }
        out
    }

    /// The convolution computed directly for `CO` outputs (`CO == self.cout`): each
    /// output pixel's `CO` sums are held together while the kernel's taps inside the image
    /// are read in place (no im2col copy, no packing), so the innermost loop, over the
    /// outputs, is a few vector operations for every input value.
    fn direct<const CO: usize>(&self, x: &Act, relu: bool, mut out: Act) -> Act {
        let (k, s, p, d, cin) = (self.k, self.stride, self.pad, self.dilation, self.cin);
        let (oh, ow) = (out.h, out.w);
        let mut bias = [0f32; CO];
        bias.copy_from_slice(&self.bias);
        for i in 0..x.n {
            for oy in 0..oh {
                let out_row = &mut out.data[(i * oh + oy) * ow * CO..][..ow * CO];
                for (ox, dst) in out_row.chunks_exact_mut(CO).enumerate() {
                    let mut acc = bias;
                    for ky in 0..k {
                        let Some(iy) = (oy * s + ky * d).checked_sub(p).filter(|&y| y < x.h) else {
                            continue;
                        };
                        for kx in 0..k {
                            let Some(ix) = (ox * s + kx * d).checked_sub(p).filter(|&v| v < x.w)
                            else {
                                continue;
                            };
                            let px = &x.data[((i * x.h + iy) * x.w + ix) * cin..][..cin];
                            let taps = &self.weights[(ky * k + kx) * cin * CO..][..cin * CO];
                            for (&v, w) in px.iter().zip(taps.chunks_exact(CO)) {
                                for (a, &w) in acc.iter_mut().zip(w) {
                                    *a += v * w;
                                }
                            }
                        }
                    }
                    if relu {
                        for a in &mut acc {
                            *a = a.max(0.0);
                        }
                    }
                    dst.copy_from_slice(&acc);
                }
            }
        }
        out
    }

    /// A dense layer over each image of the batch flattened (`[n][h·w·c]` to `[n][cout]`).
    pub fn dense(&self, x: &Act, relu: bool) -> Act {
        let cin = x.h * x.w * x.c;
        debug_assert_eq!(cin, self.cin);
        let mut out = Act::zeros(x.n, 1, 1, self.cout);
        fill_bias(&mut out.data, &self.bias);
        gemm_acc(&x.data, x.n, cin, &self.weights, self.cout, &mut out.data);
        if relu {
            relu_in_place(&mut out.data);
        }
        out
    }
}

/// One pixel's channels into an im2col row: the one- and three-channel inputs (grey
/// patches, RGB frames) element by element, which is several times faster than a call to
/// `memcpy` for so few values.
#[inline(always)]
fn copy_channels(dst: &mut [f32], src: &[f32]) {
    match (dst, src) {
        ([d], [s]) => *d = *s,
        ([d0, d1, d2], [s0, s1, s2]) => {
            *d0 = *s0;
            *d1 = *s1;
            *d2 = *s2;
        }
        (d, s) => d.copy_from_slice(s),
    }
}

/// 2×2 max pooling of stride 2 (an odd last row or column is dropped).
pub fn max_pool2(x: &Act) -> Act {
    let (oh, ow, c) = (x.h / 2, x.w / 2, x.c);
    let mut out = Act::zeros(x.n, oh, ow, c);
    for i in 0..x.n {
        for oy in 0..oh {
            for ox in 0..ow {
                let o = &mut out.data[((i * oh + oy) * ow + ox) * c..][..c];
                o.copy_from_slice(x.pixel(i, 2 * oy, 2 * ox));
                for (dy, dx) in [(0, 1), (1, 0), (1, 1)] {
                    for (a, &v) in o.iter_mut().zip(x.pixel(i, 2 * oy + dy, 2 * ox + dx)) {
                        *a = a.max(v);
                    }
                }
            }
        }
    }
    out
}

/// Why a network's weights file cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum WeightsError {
    #[error("not a safetensors weights file (truncated or another format): {0}")]
    Format(String),
    #[error("the weights file's format is {found:?}, this agent reads {expected:?}")]
    WrongFormat { found: String, expected: String },
    #[error("the weights file has no tensor {0:?}")]
    Missing(String),
    #[error(
        "tensor {name:?} is {found:?}, the network needs {expected:?} (a model for another input size or architecture)"
    )]
    Shape {
        name: String,
        expected: Vec<usize>,
        found: Vec<usize>,
    },
    #[error("tensor {0:?} is not 32-bit float")]
    DType(String),
    #[error("tensor {0:?} holds a value that is not finite")]
    NotFinite(String),
}

/// A safetensors weights file, read and checked tensor by tensor.
#[derive(Debug)]
pub struct WeightsFile<'a> {
    st: safetensors::SafeTensors<'a>,
    metadata: BTreeMap<String, String>,
}

impl<'a> WeightsFile<'a> {
    /// The file of `bytes`, which must name `format` in its metadata.
    pub fn read(bytes: &'a [u8], format: &str) -> Result<Self, WeightsError> {
        let (_, meta) = safetensors::SafeTensors::read_metadata(bytes)
            .map_err(|e| WeightsError::Format(e.to_string()))?;
        let metadata: BTreeMap<String, String> = meta
            .metadata()
            .as_ref()
            .map(|m| m.iter().map(|(k, v)| (k.clone(), v.clone())).collect())
            .unwrap_or_default();
        match metadata.get("format") {
            Some(f) if f == format => {}
            other => {
                return Err(WeightsError::WrongFormat {
                    found: other.cloned().unwrap_or_else(|| "unnamed".to_string()),
                    expected: format.to_string(),
                });
            }
        }
        let st = safetensors::SafeTensors::deserialize(bytes)
            .map_err(|e| WeightsError::Format(e.to_string()))?;
        Ok(WeightsFile { st, metadata })
    }

    pub fn metadata(&self) -> &BTreeMap<String, String> {
        &self.metadata
    }

    /// A tensor's values, which must have `shape`.
    pub fn tensor(&self, name: &str, shape: &[usize]) -> Result<Vec<f32>, WeightsError> {
        let t = self
            .st
            .tensor(name)
            .map_err(|_| WeightsError::Missing(name.to_string()))?;
        if t.dtype() != safetensors::Dtype::F32 {
            return Err(WeightsError::DType(name.to_string()));
        }
        if t.shape() != shape {
            return Err(WeightsError::Shape {
                name: name.to_string(),
                expected: shape.to_vec(),
                found: t.shape().to_vec(),
            });
        }
        let values: Vec<f32> = t
            .data()
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        if values.iter().any(|v| !v.is_finite()) {
            return Err(WeightsError::NotFinite(name.to_string()));
        }
        Ok(values)
    }

    /// A convolution's weight and bias tensors (`{name}.weight` `[out, in, k, k]`,
    /// `{name}.bias`).
    pub fn conv(
        &self,
        name: &str,
        cin: usize,
        cout: usize,
        k: usize,
        stride: usize,
        pad: usize,
    ) -> Result<Conv, WeightsError> {
        let w = self.tensor(&format!("{name}.weight"), &[cout, cin, k, k])?;
        let b = self.tensor(&format!("{name}.bias"), &[cout])?;
        Ok(Conv::from_oihw(&w, b, cin, k, stride, pad))
    }

    /// A convolution's tensors with its taps `dilation` apart (padded to keep the side at
    /// stride 1).
    pub fn conv_dilated(
        &self,
        name: &str,
        cin: usize,
        cout: usize,
        stride: usize,
        dilation: usize,
    ) -> Result<Conv, WeightsError> {
        Ok(self
            .conv(name, cin, cout, 3, stride, dilation)?
            .dilated(dilation))
    }

    /// A dense layer's tensors (`[out, channels·cells]`).
    pub fn dense(
        &self,
        name: &str,
        channels: usize,
        cells: usize,
        cout: usize,
    ) -> Result<Conv, WeightsError> {
        let w = self.tensor(&format!("{name}.weight"), &[cout, channels * cells])?;
        let b = self.tensor(&format!("{name}.bias"), &[cout])?;
        Ok(Conv::dense_from_oi(&w, b, channels, cells))
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn values(n: usize, seed: u32) -> Vec<f32> {
        let mut s = seed.wrapping_mul(2_654_435_761).max(1);
        (0..n)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 17;
                s ^= s << 5;
                (s % 2001) as f32 / 1000.0 - 1.0
            })
            .collect()
    }

    /// The textbook convolution over `[out][in][ky][kx]` weights, NHWC activations.
    fn naive_conv(x: &Act, w: &[f32], b: &[f32], k: usize, s: usize, p: usize) -> Act {
        let cout = b.len();
        let (oh, ow) = (out_side(x.h, k, s, p, 1), out_side(x.w, k, s, p, 1));
        let mut out = Act::zeros(x.n, oh, ow, cout);
        for i in 0..x.n {
            for oy in 0..oh {
                for ox in 0..ow {
                    for o in 0..cout {
                        let mut acc = b[o];
                        for ci in 0..x.c {
                            for ky in 0..k {
                                for kx in 0..k {
                                    let iy = (oy * s + ky) as i64 - p as i64;
                                    let ix = (ox * s + kx) as i64 - p as i64;
                                    if iy < 0 || ix < 0 || iy >= x.h as i64 || ix >= x.w as i64 {
                                        continue;
                                    }
                                    acc += x.pixel(i, iy as usize, ix as usize)[ci]
                                        * w[((o * x.c + ci) * k + ky) * k + kx];
                                }
                            }
                        }
                        out.data[((i * oh + oy) * ow + ox) * cout + o] = acc;
                    }
                }
            }
        }
        out
    }

    fn close(a: &[f32], b: &[f32]) {
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            assert!((x - y).abs() < 1e-4 * (1.0 + y.abs()), "{x} vs {y}");
        }
    }

    #[test]
    fn convolutions_match_the_textbook_one() {
        for &(n, h, w, cin, cout, k, s, p) in &[
            (2, 9, 11, 3, 12, 3, 2, 1),
            // Eight and sixteen outputs take the direct path.
            (2, 9, 11, 3, 8, 3, 2, 1),
            (1, 8, 8, 8, 16, 3, 1, 1),
            (1, 12, 10, 16, 16, 3, 2, 1),
            (3, 5, 7, 12, 24, 1, 1, 0),
            (1, 4, 4, 2, 3, 3, 1, 1),
        ] {
            let x = Act {
                n,
                h,
                w,
                c: cin,
                data: values(n * h * w * cin, 1),
            };
            let wt = values(cout * cin * k * k, 2);
            let b = values(cout, 3);
            let conv = Conv::from_oihw(&wt, b.clone(), cin, k, s, p);
            let got = conv.forward(&x, false, &mut Vec::new());
            let want = naive_conv(&x, &wt, &b, k, s, p);
            assert_eq!((got.h, got.w, got.c), (want.h, want.w, want.c));
            close(&got.data, &want.data);
        }
    }

    #[test]
    fn dilated_convolutions_match_spread_kernels() {
        for cout in [5, 16] {
            dilated_matches_spread(cout);
        }
    }

    fn dilated_matches_spread(cout: usize) {
        let (h, w, cin, d) = (9, 8, 3, 2);
        let x = Act {
            n: 1,
            h,
            w,
            c: cin,
            data: values(h * w * cin, 12),
        };
        let wt = values(cout * cin * 9, 13);
        let b = values(cout, 14);
        let got = Conv::from_oihw(&wt, b.clone(), cin, 3, 1, d)
            .dilated(d)
            .forward(&x, false, &mut Vec::new());
        let span = 2 * d + 1;
        let mut spread = vec![0f32; cout * cin * span * span];
        for o in 0..cout {
            for i in 0..cin {
                for ky in 0..3 {
                    for kx in 0..3 {
                        spread[((o * cin + i) * span + ky * d) * span + kx * d] =
                            wt[((o * cin + i) * 3 + ky) * 3 + kx];
                    }
                }
            }
        }
        let want = naive_conv(&x, &spread, &b, span, 1, d);
        assert_eq!((got.h, got.w), (want.h, want.w));
        close(&got.data, &want.data);
    }

    #[test]
    fn dense_layers_read_channel_major_inputs() {
        let (channels, cells, cout) = (3, 4, 7);
        let x = Act {
            n: 2,
            h: 2,
            w: 2,
            c: channels,
            data: values(2 * cells * channels, 7),
        };
        let w = values(cout * channels * cells, 8);
        let b = values(cout, 9);
        let got = Conv::dense_from_oi(&w, b.clone(), channels, cells).dense(&x, false);
        for i in 0..2 {
            for o in 0..cout {
                let mut acc = b[o];
                for c in 0..channels {
                    for cell in 0..cells {
                        acc += x.data[(i * cells + cell) * channels + c]
                            * w[o * channels * cells + c * cells + cell];
                    }
                }
                assert!((got.data[i * cout + o] - acc).abs() < 1e-4);
            }
        }
    }

    #[test]
    fn pooling_keeps_the_largest() {
        let x = Act {
            n: 1,
            h: 2,
            w: 3,
            c: 1,
            data: vec![1.0, 5.0, 9.0, 3.0, 2.0, 7.0],
        };
        let p = max_pool2(&x);
        assert_eq!((p.h, p.w), (1, 1));
        assert_eq!(p.data, vec![5.0]);
    }
}

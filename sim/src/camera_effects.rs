//! What a cheap camera does to a picture: white balance and exposure errors, gamma, defocus
//! and motion blur, sensor noise and resizing. Pure functions over [`Frame`]s, driven by
//! the caller's generator, so the randomised photos of [`crate::photo_synth`] are
//! reproducible from their seed.

use crate::render_scene::Frame;
use crate::rng::Rng;

/// Per-channel gains, exposure and gamma applied to every pixel (8-bit in, 8-bit out).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToneCurve {
    /// Multipliers of R, G and B (white balance and exposure together).
    pub gain_rgb: [f64; 3],
    /// Output = input^(1/gamma) on 0..1 values; 1 leaves the picture as it is.
    pub gamma: f64,
    /// Contrast about mid-grey; 1 leaves the picture as it is.
    pub contrast: f64,
}

impl ToneCurve {
    /// The picture through the curve (one lookup table per channel).
    pub fn apply(&self, frame: &mut Frame) {
        let luts: [[u8; 256]; 3] = std::array::from_fn(|c| {
            std::array::from_fn(|v| {
                let x = (v as f64 / 255.0 * self.gain_rgb[c]).max(0.0);
                let y = x.powf(1.0 / self.gamma.max(0.05));
                let y = 0.5 + (y - 0.5) * self.contrast;
                (y * 255.0 + 0.5).clamp(0.0, 255.0) as u8
            })
        });
        for px in frame.rgb.chunks_exact_mut(3) {
            for c in 0..3 {
                px[c] = luts[c][usize::from(px[c])];
            }
        }
    }
}

/// A box blur of `radius_px` (0 leaves the picture as it is), separable, edges clamped.
pub fn box_blur(frame: &Frame, radius_px: u32) -> Frame {
    if radius_px == 0 {
        return frame.clone();
    }
    let kernel: Vec<(i64, i64, f32)> = (-(radius_px as i64)..=radius_px as i64)
        .map(|d| (d, 0, 1.0))
        .collect();
    let pass = convolve(frame, &kernel);
    let kernel: Vec<(i64, i64, f32)> = kernel.iter().map(|&(d, _, w)| (0, d, w)).collect();
    convolve(&pass, &kernel)
}

/// Motion blur: the average of the picture shifted along a line of `length_px` at
/// `angle_rad` (a straight smear, as a moving ball or a turning head makes).
pub fn motion_blur(frame: &Frame, length_px: f64, angle_rad: f64) -> Frame {
    let steps = length_px.round() as i64;
    if steps < 1 {
        return frame.clone();
    }
    let (dx, dy) = (angle_rad.cos(), angle_rad.sin());
    let kernel: Vec<(i64, i64, f32)> = (0..=steps)
        .map(|k| {
            let t = k as f64 - steps as f64 / 2.0;
            ((t * dx).round() as i64, (t * dy).round() as i64, 1.0)
        })
        .collect();
    convolve(frame, &kernel)
}

/// Normalised convolution by a list of (dx, dy, weight) taps, edges clamped.
fn convolve(frame: &Frame, kernel: &[(i64, i64, f32)]) -> Frame {
    let (w, h) = (i64::from(frame.width), i64::from(frame.height));
    let total: f32 = kernel.iter().map(|k| k.2).sum::<f32>().max(f32::EPSILON);
    let mut out = vec![0u8; frame.rgb.len()];
    for y in 0..h {
        for x in 0..w {
            let mut acc = [0f32; 3];
            for &(dx, dy, weight) in kernel {
                let sx = (x + dx).clamp(0, w - 1);
                let sy = (y + dy).clamp(0, h - 1);
                let i = 3 * (sy * w + sx) as usize;
                for (a, &v) in acc.iter_mut().zip(&frame.rgb[i..i + 3]) {
                    *a += weight * f32::from(v);
                }
            }
            let o = 3 * (y * w + x) as usize;
            for c in 0..3 {
                out[o + c] = (acc[c] / total + 0.5).clamp(0.0, 255.0) as u8;
            }
        }
    }
    Frame {
        width: frame.width,
        height: frame.height,
        rgb: out,
    }
}

/// Sensor noise: Gaussian read noise of `sigma` levels plus shot noise growing with the
/// square root of the signal (`shot` levels at full scale), independent per channel.
pub fn add_noise(frame: &mut Frame, sigma: f64, shot: f64, rng: &mut Rng) {
    if sigma <= 0.0 && shot <= 0.0 {
        return;
    }
    for v in &mut frame.rgb {
        let x = f64::from(*v);
        let s = (sigma * sigma + shot * shot * x / 255.0).sqrt();
        *v = (x + s * rng.normal() + 0.5).clamp(0.0, 255.0) as u8;
    }
}

/// The window `[x0, x0 + w) × [y0, y0 + h)` (in source pixels, real-valued) resampled to
/// `out_w × out_h` by area averaging when shrinking and bilinear interpolation otherwise.
pub fn crop_resize(frame: &Frame, window: [f64; 4], out_w: u32, out_h: u32) -> Frame {
    let [x0, y0, w, h] = window;
    let (sx, sy) = (w / f64::from(out_w), h / f64::from(out_h));
    // Samples per output pixel along each axis: enough to cover the source footprint.
    let nx = sx.ceil().max(1.0) as usize;
    let ny = sy.ceil().max(1.0) as usize;
    let mut rgb = Vec::with_capacity(3 * out_w as usize * out_h as usize);
    for j in 0..out_h {
        for i in 0..out_w {
            let mut acc = [0f64; 3];
            for b in 0..ny {
                for a in 0..nx {
                    let u = x0 + (f64::from(i) + (a as f64 + 0.5) / nx as f64) * sx - 0.5;
                    let v = y0 + (f64::from(j) + (b as f64 + 0.5) / ny as f64) * sy - 0.5;
                    let p = bilinear(frame, u, v);
                    for c in 0..3 {
                        acc[c] += p[c];
                    }
                }
            }
            let n = (nx * ny) as f64;
            for a in acc {
                rgb.push((a / n + 0.5).clamp(0.0, 255.0) as u8);
            }
        }
    }
    Frame {
        width: out_w,
        height: out_h,
        rgb,
    }
}

/// The colour at real-valued pixel coordinates (pixel centres at integers), edges clamped.
pub fn bilinear(frame: &Frame, u: f64, v: f64) -> [f64; 3] {
    let max_x = f64::from(frame.width.saturating_sub(1));
    let max_y = f64::from(frame.height.saturating_sub(1));
    let (u, v) = (u.clamp(0.0, max_x), v.clamp(0.0, max_y));
    let (x0, y0) = (u.floor() as u32, v.floor() as u32);
    let (x1, y1) = (
        (x0 + 1).min(frame.width - 1),
        (y0 + 1).min(frame.height - 1),
    );
    let (fx, fy) = (u - f64::from(x0), v - f64::from(y0));
    let p = |x: u32, y: u32| frame.pixel(x, y).map(f64::from);
    let (a, b, c, d) = (p(x0, y0), p(x1, y0), p(x0, y1), p(x1, y1));
    std::array::from_fn(|k| {
        let top = a[k] + (b[k] - a[k]) * fx;
        let bottom = c[k] + (d[k] - c[k]) * fx;
        top + (bottom - top) * fy
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(w: u32, h: u32, rgb: [u8; 3]) -> Frame {
        Frame {
            width: w,
            height: h,
            rgb: (0..w * h).flat_map(|_| rgb).collect(),
        }
    }

    #[test]
    fn tone_curve_identity_and_gain() {
        let mut f = flat(4, 4, [100, 150, 200]);
        let before = f.clone();
        ToneCurve {
            gain_rgb: [1.0; 3],
            gamma: 1.0,
            contrast: 1.0,
        }
        .apply(&mut f);
        assert_eq!(f, before);
        ToneCurve {
            gain_rgb: [2.0, 1.0, 0.5],
            gamma: 1.0,
            contrast: 1.0,
        }
        .apply(&mut f);
        assert_eq!(f.pixel(1, 1), [200, 150, 100]);
    }

    #[test]
    fn blurs_keep_a_flat_picture_and_spread_an_edge() {
        let f = flat(9, 9, [50, 60, 70]);
        assert_eq!(box_blur(&f, 2), f);
        assert_eq!(motion_blur(&f, 5.0, 0.3), f);
        let mut edge = flat(9, 1, [0, 0, 0]);
        for x in 5..9 {
            edge.rgb[3 * x] = 255;
        }
        let smeared = motion_blur(&edge, 4.0, 0.0);
        assert!(smeared.pixel(4, 0)[0] > 0 && smeared.pixel(4, 0)[0] < 255);
    }

    #[test]
    fn resize_by_half_averages() {
        let mut f = flat(4, 2, [0, 0, 0]);
        f.rgb[0] = 200; // (0, 0) red
        let small = crop_resize(&f, [0.0, 0.0, 4.0, 2.0], 2, 1);
        assert_eq!((small.width, small.height), (2, 1));
        assert_eq!(small.pixel(0, 0)[0], 50);
        assert_eq!(small.pixel(1, 0)[0], 0);
    }

    #[test]
    fn noise_has_the_asked_spread() {
        let mut f = flat(100, 100, [128, 128, 128]);
        add_noise(&mut f, 5.0, 0.0, &mut Rng::new(3));
        let n = f.rgb.len() as f64;
        let mean = f.rgb.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
        let var = f
            .rgb
            .iter()
            .map(|&v| (f64::from(v) - mean).powi(2))
            .sum::<f64>()
            / n;
        assert!((mean - 128.0).abs() < 0.3, "{mean}");
        assert!((var.sqrt() - 5.0).abs() < 0.3, "{}", var.sqrt());
    }
}

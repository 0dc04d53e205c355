//! A greyscale image: one `f32` intensity per pixel, row-major, top-left pixel first.
//!
//! The chessboard detector works on intensities rather than colours, and on `f32` so that
//! smoothing and interpolation do not round. Values are in the range of the source (0–255
//! for 8-bit images) but nothing depends on that range.

use crate::image::{ImageError, RgbImage};

/// A greyscale image with `f32` intensities.
#[derive(Debug, Clone, PartialEq)]
pub struct GrayImage {
    width: u32,
    height: u32,
    data: Vec<f32>,
}

impl GrayImage {
    /// Builds an image from its width and height in pixels and its row-major intensities;
    /// fails unless `data.len() == width × height`.
    pub fn new(width: u32, height: u32, data: Vec<f32>) -> Result<Self, ImageError> {
        let expected = width as usize * height as usize;
        if data.len() != expected {
            return Err(ImageError::DataLength {
                width,
                height,
                channels: 1,
                expected,
                actual: data.len(),
            });
        }
        Ok(Self {
            width,
            height,
            data,
        })
    }

    /// An image of one intensity everywhere.
    pub fn filled(width: u32, height: u32, value: f32) -> Self {
        Self {
            width,
            height,
            data: vec![value; width as usize * height as usize],
        }
    }

    /// Builds an image from 8-bit intensities.
    pub fn from_luma8(width: u32, height: u32, data: &[u8]) -> Result<Self, ImageError> {
        Self::new(width, height, data.iter().map(|&v| f32::from(v)).collect())
    }

    /// The luma of an RGB frame, with the Rec. 601 weights (as JPEG and OpenCV use).
    pub fn from_rgb(image: &RgbImage) -> Self {
        let data = image
            .data()
            .chunks_exact(3)
            .map(|p| 0.299 * f32::from(p[0]) + 0.587 * f32::from(p[1]) + 0.114 * f32::from(p[2]))
            .collect();
        Self {
            width: image.width(),
            height: image.height(),
            data,
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The row-major intensities.
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// The intensity at (x, y), or `None` off the image.
    pub fn get(&self, x: u32, y: u32) -> Option<f32> {
        (x < self.width && y < self.height)
            .then(|| self.data[y as usize * self.width as usize + x as usize])
    }

    /// The intensity at (x, y) with the coordinates clamped to the image, so that filters
    /// can read past the border (which repeats the edge pixels). An empty image reads 0.
    pub fn clamped(&self, x: i64, y: i64) -> f32 {
        if self.data.is_empty() {
            return 0.0;
        }
        let x = x.clamp(0, i64::from(self.width) - 1) as usize;
        let y = y.clamp(0, i64::from(self.height) - 1) as usize;
        self.data[y * self.width as usize + x]
    }

    /// Bilinear interpolation at a sub-pixel position (pixel centres at integers), clamped
    /// at the borders.
    pub fn bilinear(&self, x: f64, y: f64) -> f32 {
        let x0 = x.floor();
        let y0 = y.floor();
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        let (xi, yi) = (x0 as i64, y0 as i64);
        let top = self.clamped(xi, yi) * (1.0 - fx) + self.clamped(xi + 1, yi) * fx;
        let bottom = self.clamped(xi, yi + 1) * (1.0 - fx) + self.clamped(xi + 1, yi + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// Sets the intensity at (x, y); does nothing off the image.
    pub fn set(&mut self, x: u32, y: u32, value: f32) {
        if x < self.width && y < self.height {
            self.data[y as usize * self.width as usize + x as usize] = value;
        }
    }

    /// A Gaussian blur with standard deviation `sigma_px`, separable, truncated at 3σ, with
    /// the border repeated. `sigma_px` ≤ 0 returns a copy.
    pub fn gaussian_blur(&self, sigma_px: f64) -> Self {
        if sigma_px <= 0.0 || self.data.is_empty() {
            return self.clone();
        }
        let radius = (3.0 * sigma_px).ceil() as i64;
        let weights: Vec<f32> = (-radius..=radius)
            .map(|d| (-(d * d) as f64 / (2.0 * sigma_px * sigma_px)).exp())
            .map(|w| w as f32)
            .collect();
        let total: f32 = weights.iter().sum();
        let weights: Vec<f32> = weights.iter().map(|w| w / total).collect();
        let (w, h) = (i64::from(self.width), i64::from(self.height));
        let mut horizontal = vec![0.0; self.data.len()];
        for y in 0..h {
            for x in 0..w {
                let mut sum = 0.0;
                for (k, weight) in weights.iter().enumerate() {
                    sum += weight * self.clamped(x + k as i64 - radius, y);
                }
                horizontal[(y * w + x) as usize] = sum;
            }
        }
        let horizontal = Self {
            width: self.width,
            height: self.height,
            data: horizontal,
        };
        let mut data = vec![0.0; self.data.len()];
        for y in 0..h {
            for x in 0..w {
                let mut sum = 0.0;
                for (k, weight) in weights.iter().enumerate() {
                    sum += weight * horizontal.clamped(x, y + k as i64 - radius);
                }
                data[(y * w + x) as usize] = sum;
            }
        }
        Self {
            width: self.width,
            height: self.height,
            data,
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn rejects_wrong_length_and_converts_rgb() {
        assert!(GrayImage::new(3, 2, vec![0.0; 5]).is_err());
        let rgb = RgbImage::filled(2, 2, [255, 255, 255]).unwrap();
        let gray = GrayImage::from_rgb(&rgb);
        assert!((gray.get(1, 1).unwrap() - 255.0).abs() < 1e-3);
        assert_eq!(gray.get(2, 0), None);
    }

    #[test]
    fn bilinear_interpolates_and_blur_keeps_constants() {
        let g = GrayImage::new(2, 1, vec![0.0, 10.0]).unwrap();
        assert!((g.bilinear(0.25, 0.0) - 2.5).abs() < 1e-6);
        assert!((g.bilinear(5.0, 3.0) - 10.0).abs() < 1e-6);
        let flat = GrayImage::filled(9, 7, 42.0).gaussian_blur(1.5);
        assert!(flat.data().iter().all(|v| (v - 42.0).abs() < 1e-3));
    }
}

//! Image buffers of the detection pipeline: an RGB8 camera frame and a binary mask of the
//! same size.
//!
//! Both are row-major with the top-left pixel first; pixel (x, y) has x to the right and y
//! downwards. The constructors check the buffer length, so every accessor that takes
//! in-range coordinates can index without further checks.
//!
//! [`gray`] holds the greyscale image that calibration and photo decoding use.

pub mod gray;

use thiserror::Error;

/// Why an image or a mask could not be built from its parts.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ImageError {
    /// The buffer does not hold exactly one entry per channel per pixel.
    #[error(
        "a {width}×{height} image with {channels} channel(s) needs {expected} bytes, got {actual}"
    )]
    DataLength {
        /// Image width, pixels.
        width: u32,
        /// Image height, pixels.
        height: u32,
        /// Bytes per pixel.
        channels: usize,
        /// Bytes the size requires (saturated at `usize::MAX` when it does not fit).
        expected: usize,
        /// Bytes supplied.
        actual: usize,
    },
    /// A mask byte is neither 0 nor 1.
    #[error("mask byte {index} is {value}; mask bytes are 0 or 1")]
    NotBinary {
        /// Index of the first offending byte.
        index: usize,
        /// Its value.
        value: u8,
    },
    /// The buffer for the requested size cannot be allocated.
    #[error("cannot allocate a {width}×{height} buffer")]
    TooLarge {
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
    },
}

/// A zeroed buffer of `len` bytes, or an error when it cannot be allocated.
fn zeroed(width: u32, height: u32, len: usize) -> Result<Vec<u8>, ImageError> {
    let mut data = Vec::new();
    if len == usize::MAX || data.try_reserve_exact(len).is_err() {
        return Err(ImageError::TooLarge { width, height });
    }
    data.resize(len, 0);
    Ok(data)
}

/// Number of bytes of a `width × height` buffer with `channels` bytes per pixel, saturated
/// at `usize::MAX` so that an impossible size never matches a real buffer.
fn buffer_len(width: u32, height: u32, channels: usize) -> usize {
    (width as usize)
        .checked_mul(height as usize)
        .and_then(|n| n.checked_mul(channels))
        .unwrap_or(usize::MAX)
}

/// Checks that `data_len` bytes make a `width × height` buffer of `channels` bytes per pixel.
fn check_len(width: u32, height: u32, channels: usize, data_len: usize) -> Result<(), ImageError> {
    let expected = buffer_len(width, height, channels);
    if data_len != expected {
        return Err(ImageError::DataLength {
            width,
            height,
            channels,
            expected,
            actual: data_len,
        });
    }
    Ok(())
}

/// A camera frame: 8-bit red, green and blue per pixel, row-major, 3 bytes per pixel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RgbImage {
    width: u32,
    height: u32,
    data: Vec<u8>,
}

impl RgbImage {
    /// Builds an image from its width and height in pixels and its row-major RGB8 bytes;
    /// fails unless `data.len() == width × height × 3`.
    pub fn new(width: u32, height: u32, data: Vec<u8>) -> Result<Self, ImageError> {
        check_len(width, height, 3, data.len())?;
        Ok(Self {
            width,
            height,
            data,
        })
    }

    /// An image filled with one colour; fails when it cannot be allocated.
    pub fn filled(width: u32, height: u32, rgb: [u8; 3]) -> Result<Self, ImageError> {
        let mut data = zeroed(width, height, buffer_len(width, height, 3))?;
        for pixel in data.chunks_exact_mut(3) {
            pixel.copy_from_slice(&rgb);
        }
        Self::new(width, height, data)
    }

    /// Width, pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height, pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The row-major RGB8 bytes.
    pub fn data(&self) -> &[u8] {
        &self.data
    }

    /// The colour of pixel (x, y), or `None` off the image.
    pub fn pixel(&self, x: u32, y: u32) -> Option<[u8; 3]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = 3 * (y as usize * self.width as usize + x as usize);
        Some([self.data[i], self.data[i + 1], self.data[i + 2]])
    }

    /// Sets pixel (x, y); does nothing off the image.
    pub fn set_pixel(&mut self, x: u32, y: u32, rgb: [u8; 3]) {
        if x >= self.width || y >= self.height {
            return;
        }
        let i = 3 * (y as usize * self.width as usize + x as usize);
        self.data[i..i + 3].copy_from_slice(&rgb);
    }

    /// Consumes the image, returning its bytes.
    pub fn into_data(self) -> Vec<u8> {
        self.data
    }
}

/// A binary mask: one byte per pixel, 1 for a selected pixel and 0 otherwise, row-major.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Mask {
    width: u32,
    height: u32,
    data: Vec<u8>,
}

impl Mask {
    /// Builds a mask from its width and height in pixels and its row-major bytes; fails
    /// unless `data.len() == width × height` and every byte is 0 or 1.
    pub fn new(width: u32, height: u32, data: Vec<u8>) -> Result<Self, ImageError> {
        check_len(width, height, 1, data.len())?;
        if let Some((index, &value)) = data.iter().enumerate().find(|&(_, &b)| b > 1) {
            return Err(ImageError::NotBinary { index, value });
        }
        Ok(Self {
            width,
            height,
            data,
        })
    }

    /// The empty mask of a size; fails when it cannot be allocated.
    #[cfg(any(test, feature = "test-support"))]
    pub fn zeros(width: u32, height: u32) -> Result<Self, ImageError> {
        let data = zeroed(width, height, buffer_len(width, height, 1))?;
        Self::new(width, height, data)
    }

    /// Builds a mask whose buffer the caller guarantees to hold `width × height` bytes of 0
    /// or 1.
    pub(crate) fn from_parts_unchecked(width: u32, height: u32, data: Vec<u8>) -> Self {
        debug_assert_eq!(data.len(), buffer_len(width, height, 1));
        Self {
            width,
            height,
            data,
        }
    }

    /// Width, pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height, pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The row-major bytes, each 0 or 1.
    pub fn data(&self) -> &[u8] {
        &self.data
    }

    /// Whether pixel (x, y) is selected; `false` off the mask.
    pub fn get(&self, x: u32, y: u32) -> bool {
        x < self.width
            && y < self.height
            && self.data[y as usize * self.width as usize + x as usize] != 0
    }

    /// Selects (`true`) or clears pixel (x, y); does nothing off the mask.
    #[cfg(any(test, feature = "test-support"))]
    pub fn set(&mut self, x: u32, y: u32, on: bool) {
        if x < self.width && y < self.height {
            self.data[y as usize * self.width as usize + x as usize] = u8::from(on);
        }
    }

    /// Number of selected pixels.
    #[cfg(any(test, feature = "test-support"))]
    pub fn count(&self) -> usize {
        self.data.iter().map(|&b| usize::from(b)).sum()
    }
}

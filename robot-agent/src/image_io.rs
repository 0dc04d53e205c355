//! Loading greyscale images from JPEG and PNG files: the only file input of the
//! calibration library, kept apart so that everything else stays a pure function.
//!
//! Grey, grey + alpha, RGB, RGBA, palette and 16-bit PNGs are reduced to 8-bit channels and
//! then to luma; grey, RGB and CMYK JPEGs likewise. The format is chosen from the file's
//! signature, not its name.

use std::io::{BufReader, Cursor};
use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::gray::GrayImage;

/// Why an image file could not be loaded.
#[derive(Debug, Error)]
pub enum ImageIoError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The operating system's reason.
        source: std::io::Error,
    },
    /// The file is neither a PNG nor a JPEG.
    #[error("{path} is neither a PNG nor a JPEG file")]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// The file looks like an image but could not be decoded.
    #[error("cannot decode {path}: {reason}")]
    Decode {
        /// The file.
        path: PathBuf,
        /// The decoder's reason.
        reason: String,
    },
}

const PNG_SIGNATURE: &[u8] = &[0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];
const JPEG_SIGNATURE: &[u8] = &[0xff, 0xd8];

/// Loads a PNG or JPEG file as a greyscale image.
pub fn load_gray(path: &Path) -> Result<GrayImage, ImageIoError> {
    let bytes = std::fs::read(path).map_err(|source| ImageIoError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let decode_error = |reason: String| ImageIoError::Decode {
        path: path.to_path_buf(),
        reason,
    };
    if bytes.starts_with(PNG_SIGNATURE) {
        decode_png(&bytes).map_err(decode_error)
    } else if bytes.starts_with(JPEG_SIGNATURE) {
        decode_jpeg(&bytes).map_err(decode_error)
    } else {
        Err(ImageIoError::UnknownFormat {
            path: path.to_path_buf(),
        })
    }
}

/// Decodes PNG bytes to greyscale.
fn decode_png(bytes: &[u8]) -> Result<GrayImage, String> {
    let mut decoder = png::Decoder::new(BufReader::new(Cursor::new(bytes)));
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder.read_info().map_err(|e| e.to_string())?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| "image too large".to_string())?;
    let mut buffer = vec![0; size];
    let info = reader.next_frame(&mut buffer).map_err(|e| e.to_string())?;
    let samples = &buffer[..info.buffer_size()];
    let channels = info.color_type.samples();
    to_gray(info.width, info.height, samples, channels)
}

/// Decodes JPEG bytes to greyscale.
fn decode_jpeg(bytes: &[u8]) -> Result<GrayImage, String> {
    let mut decoder = jpeg_decoder::Decoder::new(Cursor::new(bytes));
    let pixels = decoder.decode().map_err(|e| e.to_string())?;
    let info = decoder
        .info()
        .ok_or_else(|| "no image information".to_string())?;
    let (width, height) = (u32::from(info.width), u32::from(info.height));
    match info.pixel_format {
        jpeg_decoder::PixelFormat::L8 => to_gray(width, height, &pixels, 1),
        jpeg_decoder::PixelFormat::RGB24 => to_gray(width, height, &pixels, 3),
        jpeg_decoder::PixelFormat::L16 => {
            let data = pixels
                .chunks_exact(2)
                .map(|p| f32::from(u16::from_be_bytes([p[0], p[1]])) / 257.0)
                .collect();
            GrayImage::new(width, height, data).map_err(|e| e.to_string())
        }
        jpeg_decoder::PixelFormat::CMYK32 => {
            // Adobe CMYK JPEGs store inverted values: the intensity is their product.
            let data = pixels
                .chunks_exact(4)
                .map(|p| {
                    let [c, m, y, k] = [p[0], p[1], p[2], p[3]].map(|v| f32::from(v) / 255.0);
                    255.0 * k * (0.299 * c + 0.587 * m + 0.114 * y)
                })
                .collect();
            GrayImage::new(width, height, data).map_err(|e| e.to_string())
        }
    }
}

/// Luma of 8-bit samples with 1 (grey), 2 (grey + alpha), 3 (RGB) or 4 (RGBA) channels;
/// alpha is ignored.
fn to_gray(width: u32, height: u32, samples: &[u8], channels: usize) -> Result<GrayImage, String> {
    let data = match channels {
        1 | 2 => samples
            .chunks_exact(channels)
            .map(|p| f32::from(p[0]))
            .collect(),
        3 | 4 => samples
            .chunks_exact(channels)
            .map(|p| 0.299 * f32::from(p[0]) + 0.587 * f32::from(p[1]) + 0.114 * f32::from(p[2]))
            .collect(),
        other => return Err(format!("unsupported number of channels {other}")),
    };
    GrayImage::new(width, height, data).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn photo(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data/chessboard-photos")
            .join(name)
    }

    #[test]
    fn loads_a_greyscale_jpeg() {
        let image = load_gray(&photo("left01.jpg")).unwrap();
        assert_eq!((image.width(), image.height()), (640, 480));
        let mean = image.data().iter().sum::<f32>() / image.data().len() as f32;
        assert!((20.0..235.0).contains(&mean), "mean {mean}");
    }

    #[test]
    fn loads_an_rgb_png() {
        let dir = std::env::temp_dir().join(format!("image-io-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("rgb.png");
        {
            let file = std::fs::File::create(&path).unwrap();
            let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), 2, 1);
            encoder.set_color(png::ColorType::Rgb);
            encoder.set_depth(png::BitDepth::Eight);
            let mut writer = encoder.write_header().unwrap();
            writer.write_image_data(&[255, 255, 255, 0, 0, 0]).unwrap();
        }
        let image = load_gray(&path).unwrap();
        assert_eq!(image.data().len(), 2);
        assert!((image.data()[0] - 255.0).abs() < 0.01 && image.data()[1] == 0.0);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn clear_errors_for_missing_unknown_and_corrupt_files() {
        let missing = load_gray(Path::new("/nonexistent/board.png")).unwrap_err();
        assert!(matches!(missing, ImageIoError::Read { .. }), "{missing}");
        let readme = load_gray(&photo("README.md")).unwrap_err();
        assert!(
            matches!(readme, ImageIoError::UnknownFormat { .. }),
            "{readme}"
        );
        let dir = std::env::temp_dir().join(format!("image-io-bad-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("truncated.jpg");
        std::fs::write(&path, [0xff, 0xd8, 0xff, 0xe0, 0, 16]).unwrap();
        let corrupt = load_gray(&path).unwrap_err();
        assert!(matches!(corrupt, ImageIoError::Decode { .. }), "{corrupt}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

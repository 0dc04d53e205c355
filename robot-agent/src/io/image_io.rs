//! Images from and to JPEG and PNG: the only file input of the library, kept apart so that
//! everything else stays a pure function.
//!
//! Grey, grey + alpha, RGB, RGBA, palette and 16-bit PNGs are reduced to 8-bit channels and
//! then to luma or RGB; grey, RGB and CMYK JPEGs likewise. The format is chosen from the
//! bytes' signature, not a file name. Frames are written as PNG.

use std::io::{BufReader, Cursor};
use std::path::{Path, PathBuf};

use thiserror::Error;

use vision::GrayImage;
use vision::image::RgbImage;

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

/// Why image bytes could not be decoded or encoded.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum CodecError {
    #[error("neither a PNG nor a JPEG image")]
    UnknownFormat,
    #[error("{0}")]
    Decode(String),
    #[error("PNG encoding: {0}")]
    Encode(String),
}

/// Decoded 8-bit samples: width, height, samples, channels per pixel (1 to 4).
struct Samples {
    width: u32,
    height: u32,
    data: Vec<u8>,
    channels: usize,
}

fn read(path: &Path) -> Result<Vec<u8>, ImageIoError> {
    std::fs::read(path).map_err(|source| ImageIoError::Read {
        path: path.to_path_buf(),
        source,
    })
}

fn with_path(path: &Path, e: CodecError) -> ImageIoError {
    match e {
        CodecError::UnknownFormat => ImageIoError::UnknownFormat {
            path: path.to_path_buf(),
        },
        CodecError::Decode(reason) | CodecError::Encode(reason) => ImageIoError::Decode {
            path: path.to_path_buf(),
            reason,
        },
    }
}

/// Loads a PNG or JPEG file as a greyscale image.
pub fn load_gray(path: &Path) -> Result<GrayImage, ImageIoError> {
    decode_gray(&read(path)?).map_err(|e| with_path(path, e))
}

/// The PNG and JPEG files of a folder (by extension, any case), sorted by name.
pub fn image_files(dir: &Path) -> Result<Vec<PathBuf>, ImageIoError> {
    let read = |source| ImageIoError::Read {
        path: dir.to_path_buf(),
        source,
    };
    let mut paths = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(read)? {
        let path = entry.map_err(read)?.path();
        let image = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| matches!(e.to_ascii_lowercase().as_str(), "png" | "jpg" | "jpeg"));
        if image {
            paths.push(path);
        }
    }
    paths.sort();
    Ok(paths)
}

/// The PNG and JPEG files under `dir` and its subfolders (hidden folders skipped), sorted
/// by path: a data set of several events, one folder each.
pub fn image_files_recursive(dir: &Path) -> Result<Vec<PathBuf>, ImageIoError> {
    let mut paths = image_files(dir)?;
    let read = |source| ImageIoError::Read {
        path: dir.to_path_buf(),
        source,
    };
    let mut subdirs = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(read)? {
        let path = entry.map_err(read)?.path();
        let hidden = path
            .file_name()
            .is_some_and(|n| n.to_string_lossy().starts_with('.'));
        if path.is_dir() && !hidden {
            subdirs.push(path);
        }
    }
    subdirs.sort();
    for d in subdirs {
        paths.extend(image_files_recursive(&d)?);
    }
    paths.sort();
    Ok(paths)
}

/// Loads a PNG or JPEG file as an RGB image.
pub fn load_rgb(path: &Path) -> Result<RgbImage, ImageIoError> {
    decode_rgb(&read(path)?).map_err(|e| with_path(path, e))
}

/// Decodes PNG or JPEG bytes to greyscale.
pub fn decode_gray(bytes: &[u8]) -> Result<GrayImage, CodecError> {
    let s = decode(bytes)?;
    let data = match s.channels {
        1 | 2 => s
            .data
            .chunks_exact(s.channels)
            .map(|p| f32::from(p[0]))
            .collect(),
        _ => s
            .data
            .chunks_exact(s.channels)
            .map(|p| 0.299 * f32::from(p[0]) + 0.587 * f32::from(p[1]) + 0.114 * f32::from(p[2]))
            .collect(),
    };
    GrayImage::new(s.width, s.height, data).map_err(|e| CodecError::Decode(e.to_string()))
}

/// Decodes PNG or JPEG bytes to RGB (grey images are repeated in each channel, alpha is
/// dropped).
pub fn decode_rgb(bytes: &[u8]) -> Result<RgbImage, CodecError> {
    let s = decode(bytes)?;
    let data = match s.channels {
        1 | 2 => s
            .data
            .chunks_exact(s.channels)
            .flat_map(|p| [p[0], p[0], p[0]])
            .collect(),
        3 => s.data,
        _ => s
            .data
            .chunks_exact(s.channels)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect(),
    };
    RgbImage::new(s.width, s.height, data).map_err(|e| CodecError::Decode(e.to_string()))
}

/// Encodes an RGB image as a PNG file's bytes.
pub fn encode_png(image: &RgbImage) -> Result<Vec<u8>, CodecError> {
    let mut out = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut out, image.width(), image.height());
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_compression(png::Compression::Fast);
        let mut writer = encoder
            .write_header()
            .map_err(|e| CodecError::Encode(e.to_string()))?;
        writer
            .write_image_data(image.data())
            .map_err(|e| CodecError::Encode(e.to_string()))?;
    }
    Ok(out)
}

fn decode(bytes: &[u8]) -> Result<Samples, CodecError> {
    let s = if bytes.starts_with(PNG_SIGNATURE) {
        decode_png(bytes)
    } else if bytes.starts_with(JPEG_SIGNATURE) {
        decode_jpeg(bytes)
    } else {
        return Err(CodecError::UnknownFormat);
    }
    .map_err(CodecError::Decode)?;
    if !(1..=4).contains(&s.channels) {
        return Err(CodecError::Decode(format!(
            "unsupported number of channels {}",
            s.channels
        )));
    }
    Ok(s)
}

/// Decodes PNG bytes to 8-bit samples.
fn decode_png(bytes: &[u8]) -> Result<Samples, String> {
    let mut decoder = png::Decoder::new(BufReader::new(Cursor::new(bytes)));
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder.read_info().map_err(|e| e.to_string())?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| "image too large".to_string())?;
    let mut buffer = vec![0; size];
    let info = reader.next_frame(&mut buffer).map_err(|e| e.to_string())?;
    buffer.truncate(info.buffer_size());
    Ok(Samples {
        width: info.width,
        height: info.height,
        data: buffer,
        channels: info.color_type.samples(),
    })
}

/// Decodes JPEG bytes to 8-bit samples.
fn decode_jpeg(bytes: &[u8]) -> Result<Samples, String> {
    let mut decoder = jpeg_decoder::Decoder::new(Cursor::new(bytes));
    let pixels = decoder.decode().map_err(|e| e.to_string())?;
    let info = decoder
        .info()
        .ok_or_else(|| "no image information".to_string())?;
    let (width, height) = (u32::from(info.width), u32::from(info.height));
    let (data, channels) = match info.pixel_format {
        jpeg_decoder::PixelFormat::L8 => (pixels, 1),
        jpeg_decoder::PixelFormat::RGB24 => (pixels, 3),
        jpeg_decoder::PixelFormat::L16 => (pixels.chunks_exact(2).map(|p| p[0]).collect(), 1),
        jpeg_decoder::PixelFormat::CMYK32 => {
            // Adobe CMYK JPEGs store inverted values: each channel is its product with K.
            let data = pixels
                .chunks_exact(4)
                .flat_map(|p| {
                    let k = u16::from(p[3]);
                    [p[0], p[1], p[2]].map(|v| ((u16::from(v) * k) / 255) as u8)
                })
                .collect();
            (data, 3)
        }
    };
    Ok(Samples {
        width,
        height,
        data,
        channels,
    })
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
    fn rgb_png_round_trips() {
        let mut image = RgbImage::filled(5, 3, [10, 200, 30]).unwrap();
        image.set_pixel(4, 2, [1, 2, 3]);
        let bytes = encode_png(&image).unwrap();
        assert_eq!(decode_rgb(&bytes).unwrap(), image);
        let grey = decode_rgb(&std::fs::read(photo("left01.jpg")).unwrap()).unwrap();
        assert_eq!((grey.width(), grey.height()), (640, 480));
        assert_eq!(decode_rgb(b"not an image"), Err(CodecError::UnknownFormat));
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

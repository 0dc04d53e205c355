//! A camera's view: one frame downscaled to a small JPEG with every candidate the detector
//! scored drawn in the JPEG's pixels ([`proto::CameraView`]), for people watching what the
//! robot sees.
//!
//! The frame is area-averaged down to at most [`MAX_VIEW_SIDE_PX`] each way (aspect kept,
//! never enlarged) and encoded at falling qualities until the JPEG fits in
//! [`VIEW_JPEG_TARGET_BYTES`]; when even the lowest quality does not fit (a noisy frame),
//! the size is halved and the qualities tried again. Pure: the caller passes the stamp,
//! the sequence number and the pipeline's time.

use crate::pipeline::{FrameResult, ScoredCandidate};
use proto::{
    Camera, CameraView, CandidateOutcome, MAX_VIEW_CANDIDATES, MAX_VIEW_SIDE_PX, Pitch, Stamp,
    Validate, ValidationContext, ValidationError, ViewCandidate,
};
use thiserror::Error;
use vision::image::{ImageError, RgbImage};

/// The size a view's JPEG is brought under, bytes (the wire allows
/// [`proto::MAX_VIEW_JPEG_BYTES`]).
pub const VIEW_JPEG_TARGET_BYTES: usize = 30_000;

/// The JPEG qualities tried, best first.
const QUALITIES: [u8; 5] = [80, 65, 50, 35, 20];

/// Why a view could not be made.
#[derive(Debug, Error)]
pub enum ViewError {
    #[error("the frame is empty ({width}×{height} px)")]
    EmptyFrame { width: u32, height: u32 },
    #[error(transparent)]
    Image(#[from] ImageError),
    #[error("encoding the JPEG: {0}")]
    Encode(#[from] jpeg_encoder::EncodingError),
    #[error("no JPEG of the frame fits in {VIEW_JPEG_TARGET_BYTES} bytes")]
    TooBig,
    #[error("the view is not valid: {0}")]
    Invalid(#[from] ValidationError),
}

/// The view of `image` (a frame of `camera` captured at `stamp`) with the candidates of
/// `result` (the pipeline's outcome on it, `detector_ms` its time), as view `seq` of
/// `robot_id`. The view passes [`proto::Validate`] at its own stamp.
pub fn camera_view(
    robot_id: &str,
    seq: u64,
    camera: Camera,
    stamp: Stamp,
    image: &RgbImage,
    result: &FrameResult,
    detector_ms: f64,
) -> Result<CameraView, ViewError> {
    let (source_w, source_h) = (image.width(), image.height());
    if source_w == 0 || source_h == 0 {
        return Err(ViewError::EmptyFrame {
            width: source_w,
            height: source_h,
        });
    }
    let (width, height, jpeg) = fitting_jpeg(image)?;
    let scale = [
        f64::from(width) / f64::from(source_w),
        f64::from(height) / f64::from(source_h),
    ];
    let view = CameraView {
        version: proto::VERSION,
        robot_id: robot_id.to_string(),
        seq,
        camera,
        stamp,
        width_px: width,
        height_px: height,
        source_width_px: source_w,
        source_height_px: source_h,
        detector_ms: detector_ms.clamp(0.0, 1e6),
        candidates: view_candidates(&result.candidates, scale, [width, height]),
        jpeg_base64: proto::jpeg_base64(&jpeg),
    };
    view.validate(&ValidationContext::new(Pitch::default(), stamp))?;
    Ok(view)
}

/// The size of the view of a `width × height` frame: at most [`MAX_VIEW_SIDE_PX`] each
/// way, the frame's aspect, never larger than the frame.
pub fn view_size_px(width: u32, height: u32) -> (u32, u32) {
    let side = f64::from(MAX_VIEW_SIDE_PX);
    let s = (side / f64::from(width.max(1)))
        .min(side / f64::from(height.max(1)))
        .min(1.0);
    let fit = |n: u32| ((f64::from(n) * s).round() as u32).clamp(1, MAX_VIEW_SIDE_PX);
    (fit(width), fit(height))
}

/// The frame downscaled and encoded: the largest quality of [`QUALITIES`] that fits in
/// [`VIEW_JPEG_TARGET_BYTES`], at half the size while none does. Width, height, JPEG.
fn fitting_jpeg(image: &RgbImage) -> Result<(u32, u32, Vec<u8>), ViewError> {
    let (mut w, mut h) = view_size_px(image.width(), image.height());
    loop {
        let small = downscale(image, w, h)?;
        for quality in QUALITIES {
            let jpeg = encode_jpeg(&small, quality)?;
            if jpeg.len() <= VIEW_JPEG_TARGET_BYTES {
                return Ok((w, h, jpeg));
            }
        }
        if w == 1 && h == 1 {
            return Err(ViewError::TooBig);
        }
        (w, h) = ((w / 2).max(1), (h / 2).max(1));
    }
}

/// A baseline JPEG of `image` at `quality` (1..=100).
fn encode_jpeg(image: &RgbImage, quality: u8) -> Result<Vec<u8>, ViewError> {
    let (w, h) = (image.width(), image.height());
    let (Ok(w16), Ok(h16)) = (u16::try_from(w), u16::try_from(h)) else {
        return Err(ViewError::EmptyFrame {
            width: w,
            height: h,
        });
    };
    let mut bytes = Vec::new();
    jpeg_encoder::Encoder::new(&mut bytes, quality).encode(
        image.data(),
        w16,
        h16,
        jpeg_encoder::ColorType::Rgb,
    )?;
    Ok(bytes)
}

/// `image` resized to `width × height` (each no larger than the image's) by area
/// averaging: each output pixel is the mean of the source area it covers, partly covered
/// source pixels weighted by their share.
pub fn downscale(image: &RgbImage, width: u32, height: u32) -> Result<RgbImage, ImageError> {
    let (sw, sh) = (image.width(), image.height());
    let (width, height) = (width.clamp(1, sw.max(1)), height.clamp(1, sh.max(1)));
    if sw % width == 0 && sh % height == 0 {
        return block_average(image, sw / width, sh / height);
    }
    let (cols, rows) = (spans(sw, width), spans(sh, height));
    let src = image.data();
    let src_stride = sw as usize * 3;
    let mut data = Vec::with_capacity(width as usize * height as usize * 3);
    // Per output row: its source rows averaged into one (contiguous, so it vectorises),
    // then that row averaged across into the output's columns.
    let mut row = vec![0f32; src_stride];
    for span in &rows {
        row.fill(0.0);
        for &(j, weight) in span {
            let line = &src[j * src_stride..(j + 1) * src_stride];
            for (acc, &v) in row.iter_mut().zip(line) {
                *acc += weight * f32::from(v);
            }
        }
        for span in &cols {
            let mut rgb = [0f32; 3];
            for &(i, weight) in span {
                let p = &row[i * 3..i * 3 + 3];
                rgb[0] += weight * p[0];
                rgb[1] += weight * p[1];
                rgb[2] += weight * p[2];
            }
            data.extend(rgb.map(|v| v.round().clamp(0.0, 255.0) as u8));
        }
    }
    RgbImage::new(width, height, data)
}

/// [`downscale`] by whole factors (the usual case: 640×360 or 1280×720 to 320×180): the
/// mean of each `kx × ky` block, in integers.
fn block_average(image: &RgbImage, kx: u32, ky: u32) -> Result<RgbImage, ImageError> {
    let (width, height) = (image.width() / kx, image.height() / ky);
    let (kx, ky) = (kx as usize, ky as usize);
    let src_stride = image.width() as usize * 3;
    let n = (kx * ky) as u32;
    let mut data = Vec::with_capacity(width as usize * height as usize * 3);
    let mut row = vec![0u32; src_stride];
    for lines in image.data().chunks_exact(src_stride * ky) {
        row.fill(0);
        for line in lines.chunks_exact(src_stride) {
            for (acc, &v) in row.iter_mut().zip(line) {
                *acc += u32::from(v);
            }
        }
        for block in row.chunks_exact(kx * 3).take(width as usize) {
            let mut rgb = [0u32; 3];
            for p in block.chunks_exact(3) {
                rgb[0] += p[0];
                rgb[1] += p[1];
                rgb[2] += p[2];
            }
            // Rounded to the nearest; a mean of bytes is a byte.
            data.extend(rgb.map(|sum| ((sum + n / 2) / n) as u8));
        }
    }
    RgbImage::new(width, height, data)
}

/// For each of `out` equal cells over `n` source pixels: the source pixels it covers and
/// their weights (summing to one).
fn spans(n: u32, out: u32) -> Vec<Vec<(usize, f32)>> {
    let r = f64::from(n) / f64::from(out);
    (0..out)
        .map(|i| {
            let (a, b) = (f64::from(i) * r, f64::from(i + 1) * r);
            let first = a.floor() as u32;
            let last = (b.ceil() as u32).min(n);
            (first..last)
                .filter_map(|j| {
                    let covered = b.min(f64::from(j + 1)) - a.max(f64::from(j));
                    (covered > 0.0).then_some((j as usize, (covered / r) as f32))
                })
                .collect()
        })
        .collect()
}

/// The candidates in the view's pixels (`scale`: view pixels per frame pixel, x and y),
/// clamped into the `size` image, most probable first, at most [`MAX_VIEW_CANDIDATES`]
/// (the ball always among them).
fn view_candidates(
    candidates: &[ScoredCandidate],
    scale: [f64; 2],
    size: [u32; 2],
) -> Vec<ViewCandidate> {
    let mut kept: Vec<&ScoredCandidate> = candidates
        .iter()
        .filter(|c| {
            c.circle.center_px.iter().all(|v| v.is_finite())
                && c.circle.radius_px.is_finite()
                && c.probability.is_finite()
        })
        .collect();
    kept.sort_by(|a, b| b.probability.total_cmp(&a.probability));
    if kept.len() > MAX_VIEW_CANDIDATES {
        let ball = kept
            .iter()
            .position(|c| c.outcome == CandidateOutcome::Ball);
        if let Some(i) = ball.filter(|&i| i >= MAX_VIEW_CANDIDATES) {
            kept.swap(MAX_VIEW_CANDIDATES - 1, i);
        }
        // The ball, less probable than every candidate kept before it, stays last.
        kept.truncate(MAX_VIEW_CANDIDATES);
    }
    let (w, h) = (f64::from(size[0]), f64::from(size[1]));
    let radius_scale = 0.5 * (scale[0] + scale[1]);
    kept.into_iter()
        .map(|c| ViewCandidate {
            u_px: (c.circle.center_px[0] * scale[0]).clamp(0.0, w),
            v_px: (c.circle.center_px[1] * scale[1]).clamp(0.0, h),
            radius_px: (c.circle.radius_px * radius_scale).clamp(0.0, w.max(h)),
            score: c.probability.clamp(0.0, 1.0),
            stage: c.stage,
            outcome: c.outcome,
            reason: c.reason.map(str::to_string),
        })
        .collect()
}

#[cfg(test)]
#[path = "view_tests.rs"]
mod tests;

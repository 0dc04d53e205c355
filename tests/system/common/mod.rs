//! Helpers shared by the agent's process tests.

#![allow(dead_code, clippy::unwrap_used)]

use vision::RgbImage;

/// The image at half its size, each pixel the mean of four.
pub fn halved(image: &RgbImage) -> RgbImage {
    let (w, h) = (image.width() / 2, image.height() / 2);
    let mut data = Vec::with_capacity((w * h * 3) as usize);
    for y in 0..h {
        for x in 0..w {
            for c in 0..3 {
                let sum: u32 = [(0, 0), (1, 0), (0, 1), (1, 1)]
                    .iter()
                    .map(|(dx, dy)| u32::from(image.pixel(2 * x + dx, 2 * y + dy).unwrap()[c]))
                    .sum();
                data.push((sum / 4) as u8);
            }
        }
    }
    RgbImage::new(w, h, data).unwrap()
}

//! Binary morphology on masks: erosion, dilation, opening and closing with a square kernel.
//!
//! The kernel of radius r is the (2r + 1) × (2r + 1) square centred on the pixel. Windows
//! are clipped to the mask: pixels off the mask are neither selected nor required, so the
//! border does not erode a blob touching it. The square kernel is separable, and each pass
//! keeps running counts of selected pixels in the window, so the cost per pixel does not
//! grow with the radius.

use crate::image::Mask;

/// The two elementary operations.
#[derive(Clone, Copy)]
enum Op {
    /// Keep a pixel when every pixel of its window is selected.
    Erode,
    /// Select a pixel when any pixel of its window is selected.
    Dilate,
}

impl Op {
    #[inline]
    fn decide(self, count: u32, window: u32) -> u8 {
        match self {
            Op::Erode => u8::from(count == window),
            Op::Dilate => u8::from(count > 0),
        }
    }
}

/// One operation as a horizontal pass then a vertical pass.
fn apply(mask: &Mask, radius_px: u32, op: Op) -> Mask {
    let (w, h) = (mask.width() as usize, mask.height() as usize);
    if radius_px == 0 || w == 0 || h == 0 {
        return mask.clone();
    }
    let r = radius_px as usize;
    let src = mask.data();

    // Horizontal pass: prefix sums along each row.
    let mut horizontal = vec![0u8; w * h];
    let mut prefix = vec![0u32; w + 1];
    for (row_in, row_out) in src.chunks_exact(w).zip(horizontal.chunks_exact_mut(w)) {
        for (x, &b) in row_in.iter().enumerate() {
            prefix[x + 1] = prefix[x] + u32::from(b);
        }
        for (x, out) in row_out.iter_mut().enumerate() {
            let a = x.saturating_sub(r);
            let b = (x + r + 1).min(w);
            *out = op.decide(prefix[b] - prefix[a], (b - a) as u32);
        }
    }

    // Vertical pass: a running count per column over rows [y − r, y + r].
    let mut out = vec![0u8; w * h];
    let mut counts = vec![0u32; w];
    let row = |y: usize| &horizontal[y * w..(y + 1) * w];
    for y in 0..r.min(h) {
        for (c, &b) in counts.iter_mut().zip(row(y)) {
            *c += u32::from(b);
        }
    }
    for y in 0..h {
        if y + r < h {
            for (c, &b) in counts.iter_mut().zip(row(y + r)) {
                *c += u32::from(b);
            }
        }
        if y > r {
            for (c, &b) in counts.iter_mut().zip(row(y - r - 1)) {
                *c -= u32::from(b);
            }
        }
        let window = ((y + r + 1).min(h) - y.saturating_sub(r)) as u32;
        for (o, &c) in out[y * w..(y + 1) * w].iter_mut().zip(&counts) {
            *o = op.decide(c, window);
        }
    }
    Mask::from_parts_unchecked(mask.width(), mask.height(), out)
}

/// Erosion: a pixel stays selected when every pixel of its clipped window is selected.
pub fn erode(mask: &Mask, radius_px: u32) -> Mask {
    apply(mask, radius_px, Op::Erode)
}

/// Dilation: a pixel becomes selected when any pixel of its clipped window is selected.
pub fn dilate(mask: &Mask, radius_px: u32) -> Mask {
    apply(mask, radius_px, Op::Dilate)
}

/// Opening (erosion then dilation): removes specks and strands narrower than
/// 2 · `radius_px` + 1 pixels and never selects a pixel that was not selected.
pub fn open(mask: &Mask, radius_px: u32) -> Mask {
    dilate(&erode(mask, radius_px), radius_px)
}

/// Closing (dilation then erosion): fills holes and gaps narrower than 2 · `radius_px` + 1
/// pixels and never clears a selected pixel.
pub fn close(mask: &Mask, radius_px: u32) -> Mask {
    erode(&dilate(mask, radius_px), radius_px)
}

#[cfg(test)]
#[path = "morphology_tests.rs"]
mod tests;

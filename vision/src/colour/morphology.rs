//! Binary morphology on masks: erosion, dilation, opening and closing with a square kernel,
//! and hole filling.
//!
//! The kernel of radius r is the (2r + 1) × (2r + 1) square centred on the pixel. Windows
//! are clipped to the mask: pixels off the mask are neither selected nor required, so the
//! border does not erode a blob touching it. The square kernel is separable, and each pass
//! keeps running counts of selected pixels in the window, so the cost per pixel does not
//! grow with the radius.

use crate::image::Mask;

/// Whether a window with `count` selected pixels out of `window` gives a selected pixel:
/// all of them for erosion (`ERODE`), any of them for dilation.
#[inline(always)]
fn decide<const ERODE: bool>(count: u32, window: u32) -> u8 {
    if ERODE {
        u8::from(count == window)
    } else {
        u8::from(count != 0)
    }
}

/// One operation as a horizontal pass then a vertical pass; erosion when `ERODE`, dilation
/// otherwise.
fn apply<const ERODE: bool>(mask: &Mask, radius_px: u32) -> Mask {
    let (w, h) = (mask.width() as usize, mask.height() as usize);
    if radius_px == 0 || w == 0 || h == 0 {
        return mask.clone();
    }
    // A radius beyond the mask's size acts like one just reaching across it.
    let r = (radius_px as usize).min(w.max(h));
    let src = mask.data();

    // Horizontal pass: prefix sums along each row; the window [x − r, x + r] is clipped
    // only within r of either end, so the middle runs without clipping.
    let mut horizontal = vec![0u8; w * h];
    let mut prefix = vec![0u32; w + 1];
    let full = (2 * r + 1) as u32;
    for (row_in, row_out) in src.chunks_exact(w).zip(horizontal.chunks_exact_mut(w)) {
        let mut sum = 0u32;
        for (p, &b) in prefix[1..].iter_mut().zip(row_in) {
            sum += u32::from(b);
            *p = sum;
        }
        let edge = r.min(w);
        let middle_end = w.saturating_sub(r).max(edge);
        for (x, out) in row_out[..edge].iter_mut().enumerate() {
            let b = (x + r + 1).min(w);
            *out = decide::<ERODE>(prefix[b], b as u32);
        }
        if w > 2 * r {
            let ahead = &prefix[2 * r + 1..];
            for ((out, &hi), &lo) in row_out[edge..middle_end].iter_mut().zip(ahead).zip(&prefix) {
                *out = decide::<ERODE>(hi - lo, full);
            }
        }
        for (x, out) in row_out.iter_mut().enumerate().skip(middle_end) {
            let a = x.saturating_sub(r);
            let b = (x + r + 1).min(w);
            *out = decide::<ERODE>(prefix[b] - prefix[a], (b - a) as u32);
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
    for (y, out_row) in out.chunks_exact_mut(w).enumerate() {
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
        for (o, &c) in out_row.iter_mut().zip(&counts) {
            *o = decide::<ERODE>(c, window);
        }
    }
    Mask::from_parts_unchecked(mask.width(), mask.height(), out)
}

/// Erosion: a pixel stays selected when every pixel of its clipped window is selected.
pub fn erode(mask: &Mask, radius_px: u32) -> Mask {
    apply::<true>(mask, radius_px)
}

/// Dilation: a pixel becomes selected when any pixel of its clipped window is selected.
pub fn dilate(mask: &Mask, radius_px: u32) -> Mask {
    apply::<false>(mask, radius_px)
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

/// Hole filling: selects every unset pixel that is not connected (4-neighbour) through
/// unset pixels to the mask's border, i.e. the background that selected pixels enclose.
/// Never clears a selected pixel.
pub fn fill_holes(mask: &Mask) -> Mask {
    let (w, h) = (mask.width() as usize, mask.height() as usize);
    if w == 0 || h == 0 {
        return mask.clone();
    }
    // 0: unset and not (yet) reached from the border, 1: selected, 2: reached background.
    let mut state: Vec<u8> = mask.data().to_vec();
    let mut stack: Vec<usize> = Vec::new();
    fn seed(i: usize, state: &mut [u8], stack: &mut Vec<usize>) {
        if state[i] == 0 {
            state[i] = 2;
            stack.push(i);
        }
    }
    for x in 0..w {
        seed(x, &mut state, &mut stack);
        seed((h - 1) * w + x, &mut state, &mut stack);
    }
    for y in 0..h {
        seed(y * w, &mut state, &mut stack);
        seed(y * w + w - 1, &mut state, &mut stack);
    }
    while let Some(i) = stack.pop() {
        let (x, y) = (i % w, i / w);
        if x > 0 {
            seed(i - 1, &mut state, &mut stack);
        }
        if x + 1 < w {
            seed(i + 1, &mut state, &mut stack);
        }
        if y > 0 {
            seed(i - w, &mut state, &mut stack);
        }
        if y + 1 < h {
            seed(i + w, &mut state, &mut stack);
        }
    }
    let data = state.into_iter().map(|s| u8::from(s != 2)).collect();
    Mask::from_parts_unchecked(mask.width(), mask.height(), data)
}

#[cfg(test)]
#[path = "morphology_tests.rs"]
mod tests;

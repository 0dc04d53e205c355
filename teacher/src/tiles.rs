//! Where the teacher looks in a photo: the whole photo shrunk to its input, tiles at the
//! photo's own resolution, and tiles enlarged (small balls are blind to the network at
//! its native scale: a 12 px ball is 6 px after the photo is shrunk to 416).
//!
//! A tile's detection that touches an edge the tile shares with the rest of the photo is
//! dropped: the ball is cut there, and an overlapping tile sees it whole (tiles overlap
//! by a quarter of their width at least).

/// One window: a rectangle of the photo (pixels) seen through the square input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    pub x0: f32,
    pub y0: f32,
    /// The rectangle's side in photo pixels (the window is square; a photo's whole view
    /// is letterboxed into it).
    pub side: f32,
    /// Input pixels per photo pixel.
    pub scale: f32,
    /// Whether the window is a tile (its inner edges cut balls), not the whole photo.
    pub tile: bool,
}

/// Which passes the teacher makes over a photo.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Passes {
    /// The whole photo shrunk (or grown) to the input.
    pub whole: bool,
    /// Tiles at the photo's own resolution (skipped when the photo fits the input).
    pub native: bool,
    /// Tiles enlarged this many times (none when 1 or less).
    pub enlarge: f32,
}

impl Passes {
    /// The whole photo once: quick, blind to small balls.
    pub fn quick() -> Self {
        Passes {
            whole: true,
            native: false,
            enlarge: 0.0,
        }
    }

    /// Everything, for labelling offline: the whole photo, native tiles and tiles
    /// enlarged twice.
    pub fn labelling() -> Self {
        Passes {
            whole: true,
            native: true,
            enlarge: 2.0,
        }
    }
}

/// The windows of `passes` over a `width`×`height` photo for an `input`-pixel network.
pub fn windows(width: u32, height: u32, input: usize, passes: &Passes) -> Vec<Window> {
    let (w, h, n) = (width as f32, height as f32, input as f32);
    let mut out = Vec::new();
    if passes.whole {
        let side = w.max(h);
        out.push(Window {
            x0: 0.0,
            y0: 0.0,
            side,
            scale: n / side,
            tile: false,
        });
    }
    let mut tiles = |scale: f32| {
        let side = n / scale;
        if side >= w && side >= h {
            return;
        }
        for y0 in starts(h, side) {
            for x0 in starts(w, side) {
                out.push(Window {
                    x0,
                    y0,
                    side,
                    scale,
                    tile: true,
                });
            }
        }
    };
    if passes.native {
        tiles(1.0);
    }
    if passes.enlarge > 1.0 {
        tiles(passes.enlarge);
    }
    out
}

/// Tile starts along one axis: as few tiles as overlap by a quarter tile at least,
/// spread evenly from one end to the other.
fn starts(length: f32, side: f32) -> Vec<f32> {
    if side >= length {
        return vec![0.0];
    }
    let step_max = side * 0.75;
    let count = ((length - side) / step_max).ceil() as usize + 1;
    let step = (length - side) / (count - 1) as f32;
    (0..count).map(|i| i as f32 * step).collect()
}

/// The window's input: the photo resampled bilinearly, pixel centres aligned, with what
/// lies outside the photo filled with `fill`.
pub fn sample(
    rgb: &[u8],
    width: u32,
    height: u32,
    win: &Window,
    input: usize,
    fill: [u8; 3],
) -> Vec<[u8; 3]> {
    let (w, h) = (width as usize, height as usize);
    let mut out = vec![fill; input * input];
    let at = |x: usize, y: usize| {
        let i = (y * w + x) * 3;
        [rgb[i] as f32, rgb[i + 1] as f32, rgb[i + 2] as f32]
    };
    let xs = taps(win.x0, win.scale, input, w);
    for (oy, ty) in taps(win.y0, win.scale, input, h).into_iter().enumerate() {
        let Some((y0, y1, fy)) = ty else { continue };
        for (ox, tx) in xs.iter().enumerate() {
            let Some((x0, x1, fx)) = *tx else { continue };
            let (a, b, c, d) = (at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1));
            let mut px = [0u8; 3];
            for k in 0..3 {
                let top = a[k] + (b[k] - a[k]) * fx;
                let bottom = c[k] + (d[k] - c[k]) * fx;
                px[k] = (top + (bottom - top) * fy).round().clamp(0.0, 255.0) as u8;
            }
            out[oy * input + ox] = px;
        }
    }
    out
}

/// Along one axis, each input pixel's two photo pixels and the weight of the second
/// (`None` outside the photo): pixel centres aligned, `origin` the window's start.
fn taps(origin: f32, scale: f32, input: usize, len: usize) -> Vec<Option<(usize, usize, f32)>> {
    (0..input)
        .map(|o| {
            let s = origin + (o as f32 + 0.5) / scale - 0.5;
            if s < -0.5 || s > len as f32 - 0.5 {
                return None;
            }
            let s = s.clamp(0.0, (len - 1) as f32);
            let lower = s.floor() as usize;
            Some((lower, (lower + 1).min(len - 1), s - s.floor()))
        })
        .collect()
}

/// A box in the window's input pixels, in photo pixels; `None` when a tile's box touches
/// an edge the tile shares with the rest of the photo.
pub fn to_photo(win: &Window, b: [f32; 4], width: u32, height: u32) -> Option<[f32; 4]> {
    let p = [
        win.x0 + b[0] / win.scale,
        win.y0 + b[1] / win.scale,
        win.x0 + b[2] / win.scale,
        win.y0 + b[3] / win.scale,
    ];
    if win.tile {
        let margin = 2.0 / win.scale;
        let (w, h) = (width as f32, height as f32);
        let x1 = win.x0 + win.side;
        let y1 = win.y0 + win.side;
        let cut = (win.x0 > 0.0 && p[0] <= win.x0 + margin)
            || (win.y0 > 0.0 && p[1] <= win.y0 + margin)
            || (x1 < w && p[2] >= x1 - margin)
            || (y1 < h && p[3] >= y1 - margin);
        if cut {
            return None;
        }
    }
    Some([
        p[0].max(0.0),
        p[1].max(0.0),
        p[2].min(width as f32),
        p[3].min(height as f32),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_cover_the_photo_and_overlap() {
        let wins = windows(800, 608, 416, &Passes::labelling());
        assert!(!wins[0].tile && (wins[0].scale - 416.0 / 800.0).abs() < 1e-6);
        for scale in [1.0f32, 2.0] {
            let tiles: Vec<&Window> = wins.iter().filter(|w| w.tile && w.scale == scale).collect();
            assert!(!tiles.is_empty());
            // Every photo pixel lies in some tile at least a quarter tile from its inner edges.
            for y in (0..608).step_by(7) {
                for x in (0..800).step_by(7) {
                    let (x, y) = (x as f32, y as f32);
                    assert!(
                        tiles.iter().any(|t| x >= t.x0
                            && x < t.x0 + t.side
                            && y >= t.y0
                            && y < t.y0 + t.side)
                    );
                }
            }
            let xs: Vec<f32> = tiles.iter().filter(|t| t.y0 == 0.0).map(|t| t.x0).collect();
            for pair in xs.windows(2) {
                assert!(pair[1] - pair[0] <= tiles[0].side * 0.75 + 1e-3, "{xs:?}");
            }
            let last = tiles.iter().map(|t| t.x0 + t.side).fold(0.0, f32::max);
            assert!((last - 800.0).abs() < 1e-3);
        }
        // A photo that fits the input has no native tiles.
        let small = windows(320, 240, 416, &Passes::labelling());
        assert!(small.iter().all(|w| !w.tile || w.scale > 1.0));
    }

    #[test]
    fn a_box_cut_by_an_inner_edge_is_dropped_and_others_map_back() {
        let win = Window {
            x0: 100.0,
            y0: 0.0,
            side: 208.0,
            scale: 2.0,
            tile: true,
        };
        // In the tile's middle: mapped back at half size.
        let b = to_photo(&win, [200.0, 200.0, 240.0, 240.0], 800, 608).expect("kept");
        assert_eq!(b, [200.0, 100.0, 220.0, 120.0]);
        // Touching the left edge (inner: x0 > 0): dropped.
        assert!(to_photo(&win, [0.5, 200.0, 30.0, 230.0], 800, 608).is_none());
        // Touching the top edge, which is the photo's own: kept.
        assert!(to_photo(&win, [200.0, 0.0, 230.0, 30.0], 800, 608).is_some());
    }

    #[test]
    fn sampling_at_scale_one_copies_the_photo() {
        let (w, h) = (5u32, 4u32);
        let rgb: Vec<u8> = (0..w * h * 3).map(|i| (i * 7 % 251) as u8).collect();
        let win = Window {
            x0: 1.0,
            y0: 1.0,
            side: 3.0,
            scale: 1.0,
            tile: true,
        };
        let out = sample(&rgb, w, h, &win, 3, [9, 9, 9]);
        for oy in 0..3 {
            for ox in 0..3 {
                let i = (((oy + 1) * w as usize) + ox + 1) * 3;
                let expect = if ox + 1 < w as usize && oy + 1 < h as usize {
                    [rgb[i], rgb[i + 1], rgb[i + 2]]
                } else {
                    [9, 9, 9]
                };
                assert_eq!(out[oy * 3 + ox], expect, "at {ox},{oy}");
            }
        }
    }
}

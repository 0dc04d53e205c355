//! Connected components of a mask, 8-neighbour, by two-pass labelling with union–find.
//!
//! [`joined_components`] widens the neighbourhood: pixels up to `reach_px` apart (in both
//! directions) belong to one component, so fragments of one object separated by gaps of up
//! to `reach_px − 1` pixels (a patterned ball's ball-coloured parts around its patches)
//! come out as one component. Reach 1 is plain 8-connectivity.

use crate::image::Mask;

/// The smallest axis-aligned rectangle holding a component, inclusive pixel coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoundingBox {
    /// Leftmost column.
    pub x_min: u32,
    /// Topmost row.
    pub y_min: u32,
    /// Rightmost column.
    pub x_max: u32,
    /// Bottom row.
    pub y_max: u32,
}

/// A connected set of selected pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Component {
    /// Number of pixels.
    pub area_px: usize,
    /// Bounding box.
    pub bbox: BoundingBox,
    /// Mean of the pixel centres (u, v), pixels, with the centre of the top-left pixel at
    /// (0, 0).
    pub centroid_px: [f64; 2],
}

/// Root of a label, halving the path on the way.
fn find(parent: &mut [u32], mut a: u32) -> u32 {
    while parent[a as usize] != a {
        let grand = parent[parent[a as usize] as usize];
        parent[a as usize] = grand;
        a = grand;
    }
    a
}

/// Merges two labels' sets, keeping the smaller root.
fn union(parent: &mut [u32], a: u32, b: u32) -> u32 {
    let (ra, rb) = (find(parent, a), find(parent, b));
    let (keep, drop) = if ra < rb { (ra, rb) } else { (rb, ra) };
    parent[drop as usize] = keep;
    keep
}

/// Statistics accumulated per root label.
#[derive(Clone, Copy)]
struct Stats {
    area: usize,
    sum_x: u64,
    sum_y: u64,
    bbox: BoundingBox,
}

/// The connected components (8-neighbour) of at least `min_area_px` pixels, largest first,
/// at most `max_count` of them. Equal areas are ordered by their topmost-then-leftmost
/// pixel, so the result is deterministic.
#[cfg(test)]
pub fn largest_components(mask: &Mask, min_area_px: usize, max_count: usize) -> Vec<Component> {
    joined_components(mask, 1, min_area_px, max_count)
}

/// As [`largest_components`], with pixels up to `reach_px` apart along both axes joined
/// (reach 0 is taken as 1, plain 8-connectivity).
pub fn joined_components(
    mask: &Mask,
    reach_px: u32,
    min_area_px: usize,
    max_count: usize,
) -> Vec<Component> {
    let (w, h) = (mask.width() as usize, mask.height() as usize);
    if max_count == 0 || w == 0 || h == 0 {
        return Vec::new();
    }
    let reach = (reach_px as usize).clamp(1, w.max(h));
    let data = mask.data();
    // Label 0 is the background; labels are assigned in raster order.
    let mut labels = vec![0u32; w * h];
    let mut parent: Vec<u32> = vec![0];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if data[i] == 0 {
                continue;
            }
            let mut label = 0u32;
            let mut neighbour = |j: usize| {
                let n = labels[j];
                if n != 0 {
                    label = if label == 0 {
                        n
                    } else {
                        union(&mut parent, label, n)
                    };
                }
            };
            // Already labelled pixels within reach: to the left on this row, and the rows
            // above.
            let (x_lo, x_hi) = (x.saturating_sub(reach), (x + reach).min(w - 1));
            for j in y * w + x_lo..i {
                neighbour(j);
            }
            for yy in y.saturating_sub(reach)..y {
                for j in yy * w + x_lo..=yy * w + x_hi {
                    neighbour(j);
                }
            }
            if label == 0 {
                label = parent.len() as u32;
                parent.push(label);
            }
            labels[i] = label;
        }
    }

    let empty = Stats {
        area: 0,
        sum_x: 0,
        sum_y: 0,
        bbox: BoundingBox {
            x_min: u32::MAX,
            y_min: u32::MAX,
            x_max: 0,
            y_max: 0,
        },
    };
    let mut stats = vec![empty; parent.len()];
    for y in 0..h {
        for x in 0..w {
            let label = labels[y * w + x];
            if label == 0 {
                continue;
            }
            let s = &mut stats[find(&mut parent, label) as usize];
            let (xu, yu) = (x as u32, y as u32);
            s.area += 1;
            s.sum_x += x as u64;
            s.sum_y += y as u64;
            s.bbox.x_min = s.bbox.x_min.min(xu);
            s.bbox.y_min = s.bbox.y_min.min(yu);
            s.bbox.x_max = s.bbox.x_max.max(xu);
            s.bbox.y_max = s.bbox.y_max.max(yu);
        }
    }

    // Roots are the smallest labels of their sets, so label order is raster order of each
    // component's first pixel.
    let mut found: Vec<(usize, Stats)> = stats
        .into_iter()
        .enumerate()
        .filter(|(_, s)| s.area > 0 && s.area >= min_area_px)
        .collect();
    found.sort_by(|a, b| b.1.area.cmp(&a.1.area).then(a.0.cmp(&b.0)));
    found
        .into_iter()
        .take(max_count)
        .map(|(_, s)| Component {
            area_px: s.area,
            bbox: s.bbox,
            centroid_px: [
                s.sum_x as f64 / s.area as f64,
                s.sum_y as f64 / s.area as f64,
            ],
        })
        .collect()
}

#[cfg(test)]
#[path = "components_tests.rs"]
mod tests;

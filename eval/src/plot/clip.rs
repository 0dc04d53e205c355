//! Cutting polylines to the plot's data box before they reach plotters.

/// The pieces of a polyline inside the box `x` × `y`: segments are cut where they leave
/// it, so nothing is drawn outside the plot area and no coordinate handed to plotters is
/// far out of range (its pixel mapping would overflow).
pub(super) fn clip_polyline(
    run: &[(f64, f64)],
    x: (f64, f64),
    y: (f64, f64),
) -> Vec<Vec<(f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut open = false;
    for w in run.windows(2) {
        let Some((a, b)) = clip_segment(w[0], w[1], x, y) else {
            open = false;
            continue;
        };
        match out.last_mut() {
            Some(piece) if open && piece.last() == Some(&a) => piece.push(b),
            _ => out.push(vec![a, b]),
        }
        // The piece goes on only if the segment ended inside, uncut.
        open = b == w[1];
    }
    if let [p] = run
        && inside(*p, x, y)
    {
        out.push(vec![*p]);
    }
    out
}

pub(super) fn inside(p: (f64, f64), x: (f64, f64), y: (f64, f64)) -> bool {
    (x.0..=x.1).contains(&p.0) && (y.0..=y.1).contains(&p.1)
}

/// Liang–Barsky: the part of segment `a`–`b` inside the box, if any.
fn clip_segment(
    a: (f64, f64),
    b: (f64, f64),
    x: (f64, f64),
    y: (f64, f64),
) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    if !(dx.is_finite() && dy.is_finite()) {
        return None; // only for points near ±f64::MAX, far off any plot
    }
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a.0 - x.0),
        (dx, x.1 - a.0),
        (-dy, a.1 - y.0),
        (dy, y.1 - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
            continue;
        }
        let r = q / p;
        if p < 0.0 {
            t0 = t0.max(r);
        } else {
            t1 = t1.min(r);
        }
    }
    if t0 > t1 {
        return None;
    }
    let at = |t: f64| {
        if t == 0.0 {
            a
        } else if t == 1.0 {
            b
        } else {
            (a.0 + t * dx, a.1 + t * dy)
        }
    };
    Some((at(t0), at(t1)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polylines_are_cut_at_the_box() {
        let (x, y) = ((0.0, 10.0), (0.0, 10.0));
        let run = [(-5.0, 5.0), (5.0, 5.0), (5.0, 8.0), (5.0, 20.0), (8.0, 5.0)];
        let pieces = clip_polyline(&run, x, y);
        assert_eq!(
            pieces,
            vec![
                vec![(0.0, 5.0), (5.0, 5.0), (5.0, 8.0), (5.0, 10.0)],
                vec![(7.0, 10.0), (8.0, 5.0)],
            ]
        );
        assert!(clip_polyline(&[(-1.0, -1.0), (-1.0, 20.0)], x, y).is_empty());
        assert_eq!(clip_polyline(&[(1.0, 1.0)], x, y), vec![vec![(1.0, 1.0)]]);
        let far = clip_polyline(&[(-1e308, -1e308), (1e308, 1e308)], x, y);
        assert!(far.iter().flatten().all(|p| inside(*p, x, y)), "{far:?}");
    }
}

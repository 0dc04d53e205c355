//! The floor a simulated robot's camera reports the ball from, as the polygon a status
//! carries (`proto::CameraFootprint`).
//!
//! It is drawn from the geometry the observer decides its sightings with: the camera's
//! placement and horizontal field of view ([`cameras`], [`CameraView::sees`]), the
//! detector's range (`MIN_RANGE_M`..`MAX_RANGE_M` from the camera) and the bodies that
//! block the line of sight ([`crate::observer::occlusion`]). The fusion takes a ball
//! hypothesis that a footprint holds and that the camera's frames did not report as
//! evidence that the ball is not there, so a footprint claims no place where the simulated
//! detector could not have reported the ball, at any of the instants it stands for (a
//! status speaks for the frames around it, while the robot turns and drives).
//!
//! The polygon is star-shaped around the camera at the first instant: slices of its view,
//! each a quadrilateral from a near edge to a far edge. A slice's far edge is as far as
//! every instant's camera sees the whole quadrilateral: in range, in the field of view and
//! short of every body's shadow. So the polygon errs on the small side: a slice is cut
//! short as a whole where a shadow touches any part of it.

use crate::noise::{CameraView, HALF_FOV_RAD, MAX_RANGE_M, MIN_RANGE_M, cameras};
use crate::robots::ROBOT_RADIUS_M;
use crate::vec2::{V2, add, angle, dist, dot, from_angle, norm, scale, sub};
use proto::{CameraFootprint, Pose2};

/// Slices of the view, each 6° wide. (At most 2 corners a slice on the far edge and 21 on
/// the near one: 61, within `proto::MAX_FOOTPRINT_POINTS`.)
const SLICES: usize = 20;
/// A camera whose footprint is smaller than this claims none (a body right in front of
/// it): too little floor to be worth it.
const MIN_FOOTPRINT_AREA_M2: f64 = 0.01;

/// Where a robot and the other robots stand at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Moment<'a> {
    pub pose: Pose2,
    /// The other robots' bodies (observers or not).
    pub others: &'a [Pose2],
}

/// Each camera's footprint through `moments`: the floor where the camera reports the ball
/// at every one of them, as a polygon around the camera at the first. A camera whose view
/// is blocked (almost) entirely has none; no moments, no footprints.
pub fn camera_footprints(moments: &[Moment<'_>]) -> Vec<CameraFootprint> {
    let Some(first) = moments.first() else {
        return Vec::new();
    };
    let views: Vec<[CameraView; 2]> = moments.iter().map(|m| cameras(&m.pose)).collect();
    cameras(&first.pose)
        .iter()
        .enumerate()
        .map(|(i, reference)| {
            let looks: Vec<Look<'_>> = views
                .iter()
                .zip(moments)
                .map(|(v, m)| Look {
                    view: v[i],
                    bodies: m.others,
                })
                .collect();
            CameraFootprint {
                camera: reference.camera,
                polygon_m: polygon(reference, &looks),
            }
        })
        .filter(|f| area_m2(&f.polygon_m) >= MIN_FOOTPRINT_AREA_M2)
        .collect()
}

/// One camera and the bodies around it at one instant.
#[derive(Debug, Clone, Copy)]
struct Look<'a> {
    view: CameraView,
    bodies: &'a [Pose2],
}

/// A ray from the reference camera, along an edge of a slice of its view.
#[derive(Debug, Clone, Copy)]
struct Ray {
    from: V2,
    dir: V2,
}

impl Ray {
    fn at(&self, range_m: f64) -> V2 {
        add(self.from, scale(self.dir, range_m))
    }
}

fn cross(a: V2, b: V2) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// The ranges along `ray` that `view` has in its field of view (a convex cone: the
/// intersection of the half-planes on the inner side of its two edges), and within the
/// detector's greatest range of it. Empty when `lo > hi`.
fn in_view(ray: &Ray, view: &CameraView) -> (f64, f64) {
    let w = sub(ray.from, view.pos);
    let (mut lo, mut hi) = (0.0_f64, f64::INFINITY);
    // Inside: cross(right edge, q) ≥ 0 and cross(q, left edge) ≥ 0, q = w + r·dir.
    for (edge, sign) in [
        (from_angle(view.axis_rad - HALF_FOV_RAD), 1.0),
        (from_angle(view.axis_rad + HALF_FOV_RAD), -1.0),
    ] {
        let (c0, c1) = (sign * cross(edge, w), sign * cross(edge, ray.dir));
        if c1 > 0.0 {
            lo = lo.max(-c0 / c1);
        } else if c1 < 0.0 {
            hi = hi.min(-c0 / c1);
        } else if c0 < 0.0 {
            return (1.0, 0.0);
        }
    }
    // |w + r·dir| ≤ MAX_RANGE_M.
    let b = dot(w, ray.dir);
    let disc = b * b - dot(w, w) + MAX_RANGE_M * MAX_RANGE_M;
    if disc < 0.0 {
        return (1.0, 0.0);
    }
    (lo, hi.min(-b + disc.sqrt()))
}

/// The part of the convex polygon `poly` on the inner side of the line through `at` along
/// `dir` (left of it, or right with `sign` −1): one step of Sutherland–Hodgman clipping.
fn clip(poly: &[V2], at: V2, dir: V2, sign: f64) -> Vec<V2> {
    let side = |p: V2| sign * cross(dir, sub(p, at));
    let mut out = Vec::with_capacity(poly.len() + 1);
    for (i, p) in poly.iter().enumerate() {
        let q = poly[(i + 1) % poly.len()];
        let (sp, sq) = (side(*p), side(q));
        if sp >= 0.0 {
            out.push(*p);
        }
        if (sp >= 0.0) != (sq >= 0.0) {
            out.push(add(*p, scale(sub(q, *p), sp / (sp - sq))));
        }
    }
    out
}

/// Whether the observer would see a ball anywhere in the convex polygon `poly` past the
/// body at `body`, from a camera at `cam`. It hides a ball whose line of sight passes within
/// the body's radius of its centre beyond the centre's projection: all such balls lie in
/// the cone from the camera that just holds the body, farther than the tangent points (the
/// half-plane towards the body, from the camera on, when the camera is within it). The
/// polygon is clear when its part in that cone lies nearer than that.
fn clear_of(poly: &[V2], cam: V2, body: V2) -> bool {
    let rel = sub(body, cam);
    let d = norm(rel);
    let (half, from_m) = if d > ROBOT_RADIUS_M {
        (
            (ROBOT_RADIUS_M / d).asin(),
            (d * d - ROBOT_RADIUS_M * ROBOT_RADIUS_M).sqrt(),
        )
    } else {
        (std::f64::consts::FRAC_PI_2, 0.0)
    };
    if poly.iter().all(|p| dist(*p, cam) <= from_m) {
        return true; // All of it nearer than anything the body hides.
    }
    let towards = angle(rel);
    let right = clip(poly, cam, from_angle(towards - half), 1.0);
    let cone = clip(&right, cam, from_angle(towards + half), -1.0);
    cone.iter().all(|p| dist(*p, cam) <= from_m)
}

/// One camera's footprint polygon, counter-clockwise: the far edge from the right of the
/// view to its left, then the near edge back.
fn polygon(reference: &CameraView, looks: &[Look<'_>]) -> Vec<[f64; 2]> {
    let edge = |k: usize| -HALF_FOV_RAD + 2.0 * HALF_FOV_RAD * k as f64 / SLICES as f64;
    let half_slice = HALF_FOV_RAD / SLICES as f64;
    let ray = |off: f64| Ray {
        from: reference.pos,
        dir: from_angle(reference.axis_rad + off),
    };
    // The near edge's chords clear the detector's least range from every camera.
    let moved = looks
        .iter()
        .map(|l| dist(l.view.pos, reference.pos))
        .fold(0.0, f64::max);
    let near_m = (MIN_RANGE_M + moved) / half_slice.cos();
    let mut corners: Vec<[f64; 2]> = Vec::with_capacity(3 * SLICES + 1);
    let mut push = |p: V2| {
        if corners.last() != Some(&p) {
            corners.push(p);
        }
    };
    for k in 0..SLICES {
        let (a, b) = (ray(edge(k)), ray(edge(k + 1)));
        let far_m = slice_reach(&a, &b, near_m, looks);
        push(a.at(far_m));
        push(b.at(far_m));
    }
    for k in (0..=SLICES).rev() {
        push(ray(edge(k)).at(near_m));
    }
    corners
}

/// How far the slice between rays `a` and `b` reaches: the largest range (from `near_m` to
/// the detector's greatest) at which every look sees its whole quadrilateral. In range and
/// in the field of view are convex, so the corners decide; clear of the bodies is found by
/// bisection. `near_m` when nothing of it is seen throughout.
fn slice_reach(a: &Ray, b: &Ray, near_m: f64, looks: &[Look<'_>]) -> f64 {
    let mut far_m = MAX_RANGE_M;
    for l in looks {
        for r in [a, b] {
            let (lo, hi) = in_view(r, &l.view);
            if lo > near_m {
                return near_m;
            }
            far_m = far_m.min(hi);
        }
    }
    let clear = |far_m: f64| {
        let quad = [a.at(near_m), b.at(near_m), b.at(far_m), a.at(far_m)];
        looks.iter().all(|l| {
            l.bodies
                .iter()
                .all(|o| clear_of(&quad, l.view.pos, [o.x_m, o.y_m]))
        })
    };
    if far_m <= near_m {
        return near_m;
    }
    if clear(far_m) {
        return far_m;
    }
    // Clear at `lo` (or nothing is), not at `hi`; a millimetre is close enough.
    let (mut lo, mut hi) = (near_m, far_m);
    while hi - lo > 1e-3 {
        let mid = 0.5 * (lo + hi);
        if clear(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// A polygon's area (shoelace), m².
fn area_m2(c: &[[f64; 2]]) -> f64 {
    let n = c.len();
    let twice: f64 = (0..n)
        .map(|i| {
            let (a, b) = (c[i], c[(i + 1) % n]);
            cross(a, b)
        })
        .sum();
    twice.abs() / 2.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observer::{Occlusion, occlusion};
    use crate::rng::Rng;

    fn pose(x: f64, y: f64, theta: f64) -> Pose2 {
        Pose2 {
            x_m: x,
            y_m: y,
            theta_rad: theta,
        }
    }

    fn still(pose: Pose2, others: &[Pose2]) -> Vec<CameraFootprint> {
        camera_footprints(&[Moment { pose, others }])
    }

    /// The floor point `off_rad` from `view`'s axis, `range_m` from it.
    fn at(view: &CameraView, off_rad: f64, range_m: f64) -> V2 {
        add(
            view.pos,
            scale(from_angle(view.axis_rad + off_rad), range_m),
        )
    }

    fn inside(poly: &[[f64; 2]], p: V2) -> bool {
        proto::polygon_contains(poly, p)
    }

    /// Whether the observer could report a ball at `p` (in view, in range, not hidden).
    fn reportable(view: &CameraView, others: &[Pose2], p: V2) -> bool {
        let bodies = others.iter().map(|o| [o.x_m, o.y_m]);
        view.sees(p)
            .is_some_and(|d| (MIN_RANGE_M..=MAX_RANGE_M).contains(&d))
            && occlusion(view.pos, p, bodies, 0.04) != Occlusion::Full
    }

    #[test]
    fn a_clear_view_is_the_detectors_sector() {
        let me = pose(0.3, -0.2, 0.7);
        let fps = still(me, &[]);
        assert_eq!(fps.len(), 2);
        for (f, view) in fps.iter().zip(&cameras(&me)) {
            assert_eq!(f.camera, view.camera);
            assert_eq!(f.polygon_m.len(), 2 * (SLICES + 1));
            // Straight along the axis: in from just past the least range to just short of
            // the greatest.
            let ahead = |d: f64| at(view, 0.0, d);
            assert!(inside(&f.polygon_m, ahead(MIN_RANGE_M + 0.01)));
            assert!(inside(&f.polygon_m, ahead(MAX_RANGE_M - 0.01)));
            assert!(!inside(&f.polygon_m, ahead(MIN_RANGE_M - 0.01)));
            assert!(!inside(&f.polygon_m, ahead(MAX_RANGE_M + 0.01)));
            // Just inside and outside the field of view, 1 m out.
            assert!(inside(&f.polygon_m, at(view, HALF_FOV_RAD - 0.01, 1.0)));
            assert!(!inside(&f.polygon_m, at(view, HALF_FOV_RAD + 0.01, 1.0)));
            assert!(!inside(&f.polygon_m, at(view, -HALF_FOV_RAD - 0.01, 1.0)));
        }
    }

    #[test]
    fn a_body_in_view_cuts_its_shadow_out() {
        let me = pose(0.0, 0.0, 0.0);
        let view = cameras(&me)[0];
        let other = at(&view, 0.0, 1.0);
        let f = &still(me, &[pose(other[0], other[1], 0.0)])[0];
        assert!(
            !inside(&f.polygon_m, at(&view, 0.0, 1.5)),
            "behind the body"
        );
        assert!(inside(&f.polygon_m, at(&view, 0.0, 0.7)), "before it");
        assert!(
            inside(&f.polygon_m, at(&view, 0.5, 2.0)),
            "beside its shadow"
        );
    }

    #[test]
    fn a_turning_robot_claims_what_every_instant_sees() {
        let (from, to) = (pose(0.0, 0.0, 0.0), pose(0.05, 0.0, 0.4));
        let f = &camera_footprints(&[
            Moment {
                pose: from,
                others: &[],
            },
            Moment {
                pose: to,
                others: &[],
            },
        ])[0];
        let (v0, v1) = (cameras(&from)[0], cameras(&to)[0]);
        // The left edge of the first view is in the second; its right edge is not.
        assert!(inside(&f.polygon_m, at(&v0, HALF_FOV_RAD - 0.05, 1.0)));
        assert!(!inside(&f.polygon_m, at(&v0, -HALF_FOV_RAD + 0.05, 1.0)));
        assert!(inside(&f.polygon_m, at(&v0, 0.0, 1.0)));
        assert!(!inside(&f.polygon_m, at(&v1, HALF_FOV_RAD - 0.05, 1.0)));
    }

    #[test]
    fn the_footprint_holds_only_what_the_observer_could_report_at_every_instant() {
        // Random robots, each moved a little for a second instant, and random points: a
        // point inside a footprint is one its camera could report at both.
        let mut rng = Rng::stream(11, "footprint", 0);
        let mut held = 0;
        for _ in 0..300 {
            let me = pose(
                rng.range(-1.5, 1.5),
                rng.range(-1.0, 1.0),
                rng.range(-3.1, 3.1),
            );
            let me2 = pose(
                me.x_m + rng.range(-0.08, 0.08),
                me.y_m + rng.range(-0.08, 0.08),
                me.theta_rad + rng.range(-0.4, 0.4),
            );
            let others: Vec<Pose2> = (0..rng.range(0.0, 5.0) as usize)
                .map(|_| pose(rng.range(-1.8, 1.8), rng.range(-1.2, 1.2), 0.0))
                .collect();
            let others2: Vec<Pose2> = others
                .iter()
                .map(|o| pose(o.x_m + rng.range(-0.08, 0.08), o.y_m, 0.0))
                .collect();
            let moments = [
                Moment {
                    pose: me,
                    others: &others,
                },
                Moment {
                    pose: me2,
                    others: &others2,
                },
            ];
            let fps = camera_footprints(&moments);
            for (i, view) in cameras(&me).iter().enumerate() {
                let view2 = cameras(&me2)[i];
                let fp = fps.iter().find(|f| f.camera == view.camera);
                for _ in 0..50 {
                    let p = at(view, rng.range(-1.2, 1.2), rng.range(0.0, 2.6));
                    if fp.is_some_and(|f| inside(&f.polygon_m, p)) {
                        held += 1;
                        assert!(reportable(view, &others, p), "{me:?} {others:?} {p:?}");
                        assert!(reportable(&view2, &others2, p), "{me2:?} {others2:?} {p:?}");
                    }
                }
            }
        }
        assert!(held > 5_000, "{held}");
    }

    #[test]
    fn a_camera_against_a_body_claims_nothing() {
        let me = pose(0.0, 0.0, 0.0);
        let view = cameras(&me)[0];
        let body = at(&view, 0.0, ROBOT_RADIUS_M);
        let fps = still(me, &[pose(body[0], body[1], 0.0)]);
        assert!(fps.iter().all(|f| f.camera != view.camera), "{fps:?}");
        assert!(camera_footprints(&[]).is_empty());
    }
}

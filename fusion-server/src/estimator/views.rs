//! What the robots' cameras can see, and what it says when they do not see the ball.
//!
//! A robot's status carries each camera's floor footprint. A frame the robot reports (any
//! observation proves the camera captured it) whose footprint holds a hypothesis that the
//! frame did not report is a miss: the hypothesis's existence falls by the likelihood ratio
//! of not detecting a ball that is there, `1 − recall(range)`, with the detector's recall
//! at the ball's distance from the robot. A hit raises it. The log-odds are bounded both
//! ways, so no amount of evidence of either kind is final.
//!
//! Negative information must never cost a ball that is seen: a robot's misses do not count
//! against a hypothesis another robot saw within [`ViewConfig::veto_s`], only robots with a
//! record of sightings ([`ViewConfig::min_robot_observations`]) and no record of phantoms
//! count misses, and footprints are checked at the boundary ([`Footprint::new`]): too few
//! corners, an empty area, corners far from the robot, or the whole pitch in one camera's
//! view are refused.

use super::motion::Bounds;
use proto::Camera;
use std::collections::VecDeque;
use std::sync::Arc;
use thiserror::Error;

/// How footprints and misses are judged. `Default` is what the server runs with.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewConfig {
    /// Use negative information at all.
    pub enabled: bool,
    /// The detector's recall against the ball's distance from the robot: (range m, recall)
    /// points, linearly interpolated, the last recall held beyond the last point.
    pub recall_by_range: Vec<(f64, f64)>,
    /// Log-odds a sighting adds to its hypothesis's existence.
    pub hit_logodds: f64,
    /// Bounds of a hypothesis's existence log-odds.
    pub logodds_range: (f64, f64),
    /// A new hypothesis starts at these log-odds.
    pub initial_logodds: f64,
    /// Below this existence the main track no longer opposes a challenger.
    pub refuted_below: f64,
    /// A footprint is used for frames captured up to this long after its status.
    pub max_age_s: f64,
    /// A robot's misses do not count against a hypothesis another robot saw this recently.
    pub veto_s: f64,
    /// A robot counts misses only after this many observations of its own.
    pub min_robot_observations: u64,
    /// Footprint corners farther than this from the robot are refused.
    pub max_reach_m: f64,
    /// A status's frames without a sighting count as at most this many misses: misses of
    /// one camera in a row are not independent (the same occlusion, the same glare).
    pub max_frames_per_status: f64,
}

impl Default for ViewConfig {
    fn default() -> Self {
        ViewConfig {
            enabled: true,
            // Conservative: the detector's measured recall is 97–100 % for balls of every
            // image size in the simulator's scenes, far lower for a small patterned ball
            // far away (docs/accuracy.md); a recall taken too high would refute real balls.
            recall_by_range: vec![(0.0, 0.8), (1.5, 0.8), (2.5, 0.4), (3.0, 0.0)],
            hit_logodds: 2.5,
            logodds_range: (-6.0, 4.0),
            initial_logodds: 1.0,
            refuted_below: 0.2,
            max_age_s: 1.0,
            veto_s: 0.3,
            min_robot_observations: 20,
            max_reach_m: 10.0,
            max_frames_per_status: 3.0,
        }
    }
}

impl ViewConfig {
    /// Recall at `range_m` from the robot.
    pub fn recall_at(&self, range_m: f64) -> f64 {
        let curve = &self.recall_by_range;
        let Some(first) = curve.first() else {
            return 0.0;
        };
        if !range_m.is_finite() {
            return 0.0;
        }
        if range_m <= first.0 {
            return first.1.clamp(0.0, 1.0);
        }
        for w in curve.windows(2) {
            let ((r0, p0), (r1, p1)) = (w[0], w[1]);
            if range_m <= r1 {
                let s = if r1 > r0 {
                    (range_m - r0) / (r1 - r0)
                } else {
                    1.0
                };
                return (p0 + s * (p1 - p0)).clamp(0.0, 1.0);
            }
        }
        curve.last().map_or(0.0, |l| l.1.clamp(0.0, 1.0))
    }

    /// Checks the settings a configuration file may set.
    pub fn check(&self) -> Result<(), String> {
        let mut last = f64::NEG_INFINITY;
        for (r, p) in &self.recall_by_range {
            if !(r.is_finite() && *r >= last && (0.0..=1.0).contains(p)) {
                return Err(format!(
                    "recall_by_range must be (range ≥ 0, increasing; recall in 0..1) pairs, not ({r}, {p})"
                ));
            }
            last = *r;
        }
        Ok(())
    }
}

/// Existence probability of a hypothesis from its log-odds.
pub fn existence(logodds: f64) -> f64 {
    1.0 / (1.0 + (-logodds).exp())
}

/// Why a footprint was refused.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FootprintError {
    #[error("a footprint needs at least 3 corners, not {0}")]
    TooFewCorners(usize),
    #[error("a footprint corner is not finite")]
    NotFinite,
    #[error("the footprint encloses no area ({0:.4} m²)")]
    NoArea(f64),
    #[error("a footprint corner is {0:.1} m from the robot, beyond any camera's reach")]
    TooFar(f64),
    #[error("the footprint covers the whole pitch")]
    WholePitch,
}

/// One camera's floor footprint, checked.
#[derive(Debug, Clone, PartialEq)]
pub struct Footprint {
    corners: Vec<[f64; 2]>,
    /// Bounding box: x_min, y_min, x_max, y_max.
    bbox: [f64; 4],
}

impl Footprint {
    /// The least area a footprint must enclose, m².
    pub const MIN_AREA_M2: f64 = 1e-3;

    /// Checks a polygon reported by a robot at `robot_m`.
    pub fn new(
        corners: &[[f64; 2]],
        robot_m: [f64; 2],
        bounds: &Bounds,
        cfg: &ViewConfig,
    ) -> Result<Footprint, FootprintError> {
        if corners.len() < 3 {
            return Err(FootprintError::TooFewCorners(corners.len()));
        }
        if corners.iter().flatten().any(|v| !v.is_finite()) {
            return Err(FootprintError::NotFinite);
        }
        let reach = corners
            .iter()
            .map(|c| (c[0] - robot_m[0]).hypot(c[1] - robot_m[1]))
            .fold(0.0, f64::max);
        if reach > cfg.max_reach_m {
            return Err(FootprintError::TooFar(reach));
        }
        let area = shoelace(corners).abs();
        if area < Self::MIN_AREA_M2 {
            return Err(FootprintError::NoArea(area));
        }
        let mut bbox = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        for c in corners {
            bbox = [
                bbox[0].min(c[0]),
                bbox[1].min(c[1]),
                bbox[2].max(c[0]),
                bbox[3].max(c[1]),
            ];
        }
        let f = Footprint {
            corners: corners.to_vec(),
            bbox,
        };
        let pitch_corners = [
            [bounds.x_min, bounds.y_min],
            [bounds.x_max, bounds.y_min],
            [bounds.x_max, bounds.y_max],
            [bounds.x_min, bounds.y_max],
        ];
        if pitch_corners.iter().all(|c| f.contains(*c)) {
            return Err(FootprintError::WholePitch);
        }
        Ok(f)
    }

    /// Whether `p` lies inside (even–odd rule, so a folded outline is still answered).
    pub fn contains(&self, p: [f64; 2]) -> bool {
        let b = &self.bbox;
        if !(p[0] >= b[0] && p[0] <= b[2] && p[1] >= b[1] && p[1] <= b[3]) {
            return false;
        }
        proto::polygon_contains(&self.corners, p)
    }
}

fn shoelace(c: &[[f64; 2]]) -> f64 {
    let n = c.len();
    (0..n)
        .map(|i| {
            let (a, b) = (c[i], c[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
        / 2.0
}

#[derive(Debug, Clone, PartialEq)]
struct View {
    t_s: f64,
    camera: Camera,
    footprint: Arc<Footprint>,
}

/// The robots' recent footprints, a few per camera, so a frame is judged by the footprint
/// of its time even when it is replayed late.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Views {
    robots: Vec<(Arc<str>, VecDeque<View>)>,
}

/// Footprints kept per robot (both cameras together).
const VIEWS_PER_ROBOT: usize = 16;
/// Robots whose footprints are kept at most; past this the one whose newest is oldest goes.
const MAX_ROBOTS: usize = 256;

impl Views {
    /// Keeps `footprint` of `robot`'s `camera` from its status captured at `t_s`.
    pub fn record(&mut self, robot: &str, camera: Camera, t_s: f64, footprint: Footprint) {
        let i = match self.robots.iter().position(|(r, _)| **r == *robot) {
            Some(i) => i,
            None => {
                if self.robots.len() >= MAX_ROBOTS
                    && let Some(oldest) = (0..self.robots.len()).min_by(|a, b| {
                        let newest = |k: &usize| {
                            self.robots[*k]
                                .1
                                .back()
                                .map_or(f64::NEG_INFINITY, |v| v.t_s)
                        };
                        newest(a).total_cmp(&newest(b))
                    })
                {
                    self.robots.swap_remove(oldest);
                }
                self.robots.push((Arc::from(robot), VecDeque::new()));
                self.robots.len() - 1
            }
        };
        let list = &mut self.robots[i].1;
        let view = View {
            t_s,
            camera,
            footprint: Arc::new(footprint),
        };
        // Statuses arrive in order as a rule; one out of order is put in its place.
        let at = list.partition_point(|v| v.t_s <= t_s);
        list.insert(at, view);
        while list.len() > VIEWS_PER_ROBOT {
            list.pop_front();
        }
    }

    /// The footprint `robot`'s `camera` had at `t_s`: the newest from at most `max_age_s`
    /// before it.
    pub fn at(&self, robot: &str, camera: Camera, t_s: f64, max_age_s: f64) -> Option<&Footprint> {
        let (_, list) = self.robots.iter().find(|(r, _)| **r == *robot)?;
        list.iter()
            .rev()
            .filter(|v| v.camera == camera && v.t_s <= t_s)
            .find(|v| t_s - v.t_s <= max_age_s)
            .map(|v| &*v.footprint)
    }

    /// Robots with footprints kept.
    pub fn robots(&self) -> usize {
        self.robots.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::Pitch;

    fn bounds() -> Bounds {
        Bounds::from_pitch(&Pitch::default())
    }

    fn square(x: f64, y: f64, side: f64) -> Vec<[f64; 2]> {
        vec![[x, y], [x + side, y], [x + side, y + side], [x, y + side]]
    }

    #[test]
    fn a_footprint_holds_what_it_encloses() {
        let cfg = ViewConfig::default();
        // A concave (L-shaped) outline.
        let l = [
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 0.4],
            [0.4, 0.4],
            [0.4, 1.0],
            [0.0, 1.0],
        ];
        let f = Footprint::new(&l, [0.0, 0.0], &bounds(), &cfg).expect("valid");
        assert!(f.contains([0.2, 0.2]) && f.contains([0.8, 0.2]) && f.contains([0.2, 0.8]));
        assert!(!f.contains([0.8, 0.8]) && !f.contains([-0.1, 0.5]) && !f.contains([2.0, 2.0]));
    }

    #[test]
    fn bad_footprints_are_refused_with_the_reason() {
        let cfg = ViewConfig::default();
        let b = bounds();
        let at = [0.0, 0.0];
        let err = |c: &[[f64; 2]]| Footprint::new(c, at, &b, &cfg).err();
        assert_eq!(
            err(&[[0.0, 0.0], [1.0, 0.0]]),
            Some(FootprintError::TooFewCorners(2))
        );
        assert_eq!(
            err(&[[0.0, 0.0], [f64::NAN, 0.0], [0.0, 1.0]]),
            Some(FootprintError::NotFinite)
        );
        assert!(matches!(
            err(&[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]),
            Some(FootprintError::NoArea(_))
        ));
        assert!(matches!(
            err(&square(0.0, 0.0, 20.0)),
            Some(FootprintError::TooFar(_))
        ));
        assert_eq!(
            err(&square(-2.5, -2.5, 5.0)),
            Some(FootprintError::WholePitch)
        );
        assert_eq!(err(&square(0.0, 0.0, 1.0)), None);
    }

    #[test]
    fn recall_is_interpolated_by_range_and_zero_beyond_reach() {
        let cfg = ViewConfig::default();
        assert_eq!(cfg.recall_at(1.0), 0.8);
        assert!((cfg.recall_at(2.0) - 0.6).abs() < 1e-12);
        assert_eq!(cfg.recall_at(5.0), 0.0);
        assert_eq!(cfg.recall_at(f64::NAN), 0.0);
        assert!(cfg.check().is_ok());
        let bad = ViewConfig {
            recall_by_range: vec![(1.0, 0.5), (0.5, 0.5)],
            ..ViewConfig::default()
        };
        assert!(bad.check().is_err());
    }

    #[test]
    fn a_frame_is_judged_by_the_footprint_of_its_time() {
        let cfg = ViewConfig::default();
        let b = bounds();
        let mut v = Views::default();
        let f = |x| Footprint::new(&square(x, 0.0, 0.5), [x, 0.0], &b, &cfg).expect("valid");
        v.record("r", Camera::Left, 1.0, f(0.0));
        v.record("r", Camera::Left, 2.0, f(1.0));
        v.record("r", Camera::Left, 1.5, f(0.5)); // Out of order.
        let at = |t| v.at("r", Camera::Left, t, 1.0).map(|f| f.bbox[0]);
        assert_eq!(at(0.5), None);
        assert_eq!(at(1.2), Some(0.0));
        assert_eq!(at(1.7), Some(0.5));
        assert_eq!(at(2.5), Some(1.0));
        assert_eq!(at(3.5), None, "too old");
        assert_eq!(v.at("r", Camera::Right, 2.5, 1.0), None);
        assert_eq!(v.at("other", Camera::Left, 2.5, 1.0), None);
        for k in 0..100 {
            v.record("r", Camera::Left, 3.0 + k as f64, f(0.0));
        }
        assert_eq!(v.robots[0].1.len(), VIEWS_PER_ROBOT);
        for k in 0..(MAX_ROBOTS + 10) {
            v.record(&format!("x{k}"), Camera::Left, 500.0 + k as f64, f(0.0));
        }
        assert_eq!(v.robots(), MAX_ROBOTS);
    }
}

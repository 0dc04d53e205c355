//! Labels made by the teacher (the `teacher` crate's COCO detector), for training without
//! a person: each photo's sports balls split by score into labels, doubts and nothing, and
//! what the teacher calls something else (a person, a bottle, a clock) kept as named
//! negatives.
//!
//! A photo with a doubt is not a photo without a ball: its doubtful box may be the ball
//! the teacher half sees. Such photos are left out of training (and listed), not taught as
//! background. In a recording, frames lend each other labels ([`lend_labels`]): a doubt
//! where the ball seen before and after should be is a ball; a sure ball far from where
//! both neighbours put it is a doubt.

use crate::labels::BallBox;
use teacher::{Passes, Teacher, TeacherError};
use vision::image::RgbImage;

/// How the teacher's scores become labels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TeacherLabelling {
    pub passes: Passes,
    /// A sports ball scoring at least this is labelled a ball.
    pub accept: f64,
    /// A sports ball scoring at least this (and less than `accept`) makes the photo
    /// doubtful; below it, a box is ignored.
    pub doubt: f64,
    /// Another class scoring at least this is a named negative.
    pub negative: f64,
    /// One ball a photo, as in a match: in a photo with a sure ball, a doubt is taken for
    /// something else and does not make the photo doubtful (it is kept apart, as
    /// `beside`). Off for photos that often hold several balls.
    pub one_ball: bool,
}

impl Default for TeacherLabelling {
    /// The thresholds chosen from the teacher's curve on real robot-football photos
    /// (docs/accuracy.md, "The labelling teacher on real photos"): near 0.55 its boxes
    /// are mostly balls; down to 0.05 it still reaches balls, so a photo with anything
    /// between is doubtful rather than empty (a ball the teacher half sees must not be
    /// taught as background).
    fn default() -> Self {
        TeacherLabelling {
            passes: Passes::labelling(),
            accept: 0.55,
            doubt: 0.05,
            negative: 0.5,
            one_ball: true,
        }
    }
}

/// One thing the teacher labelled, its box in pixels (pixel centres at integers) and score.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Taught {
    pub ball_box: BallBox,
    pub score: f64,
}

/// The teacher's labels of one photo.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PhotoLabels {
    pub balls: Vec<Taught>,
    pub doubts: Vec<Taught>,
    /// Doubts in a photo with a sure ball, under `one_ball`: taken for something else.
    pub beside: Vec<Taught>,
    /// Other classes (COCO names) scoring at least `negative`.
    pub negatives: Vec<(&'static str, Taught)>,
}

impl PhotoLabels {
    /// Whether the photo can be taught as it is: no doubt in it.
    pub fn certain(&self) -> bool {
        self.doubts.is_empty()
    }
}

/// A teacher's detection as a label box (the teacher's pixel edges sit half a pixel from
/// the labels', whose pixel centres are at integers) with its score.
pub fn taught(d: &teacher::Detection) -> Taught {
    let [x0, y0, x1, y1] = d.box_px.map(|v| f64::from(v) - 0.5);
    Taught {
        ball_box: BallBox {
            x_min_px: x0,
            y_min_px: y0,
            x_max_px: x1,
            y_max_px: y1,
        },
        score: f64::from(d.score),
    }
}

/// The teacher's labels of `image`.
pub fn label_photo(
    teacher: &Teacher,
    image: &RgbImage,
    how: &TeacherLabelling,
) -> Result<PhotoLabels, TeacherError> {
    let floor = how.doubt.min(how.negative).min(how.accept) as f32;
    let found = teacher.detect(
        image.data(),
        image.width(),
        image.height(),
        &how.passes,
        floor,
    )?;
    let mut out = PhotoLabels::default();
    for d in found {
        let taught = taught(&d);
        if taught.ball_box.width_px() <= 0.0 || taught.ball_box.height_px() <= 0.0 {
            continue;
        }
        if d.class == teacher::SPORTS_BALL {
            if taught.score >= how.accept {
                out.balls.push(taught);
            } else if taught.score >= how.doubt {
                out.doubts.push(taught);
            }
        } else if taught.score >= how.negative {
            out.negatives.push((d.class_name(), taught));
        }
    }
    if how.one_ball && !out.balls.is_empty() {
        out.beside = std::mem::take(&mut out.doubts);
    }
    Ok(out)
}

/// How far, in ball widths, a ball may stand from where its neighbours put it.
const AGREE_WIDTHS: f64 = 1.0;

/// How far, in ball widths per frame between them, the neighbours' balls may lie apart
/// and still be one ball moving (a kicked ball crosses a frame in a few widths a frame).
const MOVE_WIDTHS_PER_FRAME: f64 = 3.0;

/// Frames of a recording lending each other labels, `frames` in time order with their
/// capture times: where the frames on both sides (at most `max_gap` frames away) hold one
/// ball each, the ball between is expected on the line between them. A doubt there
/// becomes a ball; a lone sure ball far from it becomes a doubt (one ball per frame, moving
/// smoothly). A frame whose doubt became its ball keeps its other doubts apart
/// (`beside`). Returns how many boxes were promoted and demoted.
pub fn lend_labels(frames: &mut [(f64, PhotoLabels)], max_gap: usize) -> (usize, usize) {
    let one_ball: Vec<Option<BallBox>> = frames
        .iter()
        .map(|(_, f)| (f.balls.len() == 1 && f.certain()).then(|| f.balls[0].ball_box))
        .collect();
    let mut promoted = 0;
    let mut demoted = 0;
    for k in 0..frames.len() {
        let before = (k.saturating_sub(max_gap)..k)
            .rev()
            .find_map(|i| one_ball[i].map(|b| (i, b)));
        let after =
            (k + 1..(k + 1 + max_gap).min(frames.len())).find_map(|i| one_ball[i].map(|b| (i, b)));
        let (Some((i, a)), Some((j, b))) = (before, after) else {
            continue;
        };
        let (ti, tj, tk) = (frames[i].0, frames[j].0, frames[k].0);
        let f = if tj > ti {
            ((tk - ti) / (tj - ti)).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let lerp = |p: f64, q: f64| p + (q - p) * f;
        let expected = BallBox {
            x_min_px: lerp(a.x_min_px, b.x_min_px),
            y_min_px: lerp(a.y_min_px, b.y_min_px),
            x_max_px: lerp(a.x_max_px, b.x_max_px),
            y_max_px: lerp(a.y_max_px, b.y_max_px),
        };
        // The neighbours must agree with each other for the expectation to mean anything.
        let gap_widths = distance(&a, &b) / expected.width_px().max(1.0);
        if gap_widths > MOVE_WIDTHS_PER_FRAME * (j - i) as f64 {
            continue;
        }
        let near = |t: &Taught| {
            distance(&t.ball_box, &expected) <= AGREE_WIDTHS * expected.width_px().max(1.0)
        };
        let labels = &mut frames[k].1;
        if let Some(pos) = labels.doubts.iter().position(near)
            && labels.balls.iter().all(|t| !near(t))
            && labels.doubts.iter().filter(|t| near(t)).count() == 1
        {
            let t = labels.doubts.remove(pos);
            labels.balls.push(t);
            // The frame's one ball is found: its other doubts are something else.
            labels.beside.append(&mut labels.doubts);
            promoted += 1;
        }
        if labels.balls.len() == 1 && !near(&labels.balls[0]) {
            let t = labels.balls.remove(0);
            labels.doubts.push(t);
            demoted += 1;
        }
    }
    (promoted, demoted)
}

/// How the robot's own detector, trained on the teacher's sure labels (the student),
/// settles what the teacher doubts: two detectors that learned differently rarely make
/// the same mistake.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Agreement {
    /// A doubt the student gives at least this probability is the photo's ball (when it
    /// is the only such doubt).
    pub promote: f64,
    /// A sure ball the student gives less than this becomes a doubt.
    pub demote: f64,
    /// One ball a photo (as in [`TeacherLabelling::one_ball`]).
    pub one_ball: bool,
}

impl Default for Agreement {
    fn default() -> Self {
        Agreement {
            promote: 0.9,
            demote: 0.05,
            one_ball: true,
        }
    }
}

/// What the student changed in a photo's labels.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Settled {
    /// Doubts that became balls.
    pub promoted: usize,
    /// Sure balls that became doubts.
    pub demoted: usize,
}

impl std::ops::AddAssign for Settled {
    fn add_assign(&mut self, o: Settled) {
        self.promoted += o.promoted;
        self.demoted += o.demoted;
    }
}

/// The student's word on one photo's labels: `student(box)` is its probability that the
/// box holds a ball (`None`: it cannot judge the box, which then stays as it is). A sure
/// ball the student calls background becomes a doubt; then, in a photo with no sure ball
/// left, the one doubt the student is sure of becomes the ball (under `one_ball`, the
/// other doubts are then something else). Two or more doubts the student is sure of leave
/// the photo doubtful. A photo the student cannot settle stays out of training.
pub fn settle(
    labels: &mut PhotoLabels,
    how: &Agreement,
    mut student: impl FnMut(&BallBox) -> Option<f64>,
) -> Settled {
    let mut out = Settled::default();
    let (kept, dropped): (Vec<Taught>, Vec<Taught>) = labels
        .balls
        .drain(..)
        .partition(|t| student(&t.ball_box).is_none_or(|p| p >= how.demote));
    out.demoted = dropped.len();
    labels.balls = kept;
    labels.doubts.extend(dropped);
    if how.one_ball && labels.balls.is_empty() {
        // The sure ball is gone: what was taken for something else beside it is in doubt.
        labels.doubts.append(&mut labels.beside);
    }
    if how.one_ball && !labels.balls.is_empty() {
        if out.demoted > 0 {
            labels.beside.append(&mut labels.doubts);
        }
        return out;
    }
    let sure: Vec<usize> = labels
        .doubts
        .iter()
        .enumerate()
        .filter(|(_, t)| student(&t.ball_box).is_some_and(|p| p >= how.promote))
        .map(|(k, _)| k)
        .collect();
    if how.one_ball {
        if let [k] = sure[..] {
            let t = labels.doubts.remove(k);
            labels.balls.push(t);
            labels.beside.append(&mut labels.doubts);
            out.promoted = 1;
        }
    } else {
        for k in sure.into_iter().rev() {
            let t = labels.doubts.remove(k);
            labels.balls.push(t);
            out.promoted += 1;
        }
    }
    out
}

/// The teacher's labels of photos against a person's labels of the same photos.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Against {
    /// The teacher's balls, and those whose centre lies in a person's ball (one each:
    /// so also the person's balls the teacher labelled).
    pub taught: usize,
    pub right: usize,
    /// The person's balls.
    pub theirs: usize,
}

impl std::ops::AddAssign for Against {
    fn add_assign(&mut self, o: Against) {
        self.taught += o.taught;
        self.right += o.right;
        self.theirs += o.theirs;
    }
}

/// One photo's balls as the teacher labelled them (`taught`) against a person's
/// (`theirs`): a taught ball is right when its centre lies in a person's ball no other
/// taught ball took.
pub fn against(taught: &[BallBox], theirs: &[BallBox]) -> Against {
    let mut taken = vec![false; theirs.len()];
    let mut right = 0;
    for t in taught {
        let c = t.centre_px();
        if let Some(k) = (0..theirs.len()).find(|&k| !taken[k] && theirs[k].contains(c)) {
            taken[k] = true;
            right += 1;
        }
    }
    Against {
        taught: taught.len(),
        right,
        theirs: theirs.len(),
    }
}

fn distance(a: &BallBox, b: &BallBox) -> f64 {
    let (p, q) = (a.centre_px(), b.centre_px());
    (p[0] - q[0]).hypot(p[1] - q[1])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn taught(x: f64, score: f64) -> Taught {
        Taught {
            ball_box: BallBox {
                x_min_px: x,
                y_min_px: 10.0,
                x_max_px: x + 10.0,
                y_max_px: 20.0,
            },
            score,
        }
    }

    fn frame(t: f64, balls: Vec<Taught>, doubts: Vec<Taught>) -> (f64, PhotoLabels) {
        (
            t,
            PhotoLabels {
                balls,
                doubts,
                ..PhotoLabels::default()
            },
        )
    }

    #[test]
    fn a_doubt_on_the_balls_path_becomes_a_ball_and_a_jump_a_doubt() {
        let mut frames = vec![
            frame(0.0, vec![taught(0.0, 0.9)], vec![]),
            // Half way along the path: the doubt at 5 is the ball, the one at 200 is not.
            frame(0.1, vec![], vec![taught(5.0, 0.3), taught(200.0, 0.3)]),
            frame(0.2, vec![taught(10.0, 0.9)], vec![]),
            // A sure ball far off the path between its neighbours.
            frame(0.3, vec![taught(300.0, 0.8)], vec![]),
            frame(0.4, vec![taught(20.0, 0.9)], vec![]),
        ];
        let (promoted, demoted) = lend_labels(&mut frames, 3);
        assert_eq!((promoted, demoted), (1, 1));
        assert_eq!(frames[1].1.balls, vec![taught(5.0, 0.3)]);
        assert_eq!(frames[1].1.beside, vec![taught(200.0, 0.3)]);
        assert!(frames[1].1.certain());
        assert!(frames[3].1.balls.is_empty());
        assert!(!frames[3].1.certain());
    }

    /// A student that knows the ball is at x = 5 and nowhere else.
    fn student(b: &BallBox) -> Option<f64> {
        Some(if (b.x_min_px - 5.0).abs() < 1.0 {
            0.97
        } else {
            0.01
        })
    }

    #[test]
    fn the_student_settles_a_doubt_and_unseats_a_wrong_sure_ball() {
        let how = Agreement::default();
        // The teacher doubts the ball and the student is sure of it.
        let mut doubted = frame(0.0, vec![], vec![taught(5.0, 0.3), taught(200.0, 0.2)]).1;
        let s = settle(&mut doubted, &how, student);
        assert_eq!(
            s,
            Settled {
                promoted: 1,
                demoted: 0
            }
        );
        assert_eq!(doubted.balls, vec![taught(5.0, 0.3)]);
        assert_eq!(doubted.beside, vec![taught(200.0, 0.2)]);
        assert!(doubted.certain());
        // The teacher was sure of a lamp, and doubted the ball beside it.
        let mut wrong = PhotoLabels {
            balls: vec![taught(100.0, 0.7)],
            beside: vec![taught(5.0, 0.1)],
            ..PhotoLabels::default()
        };
        let s = settle(&mut wrong, &how, student);
        assert_eq!(
            s,
            Settled {
                promoted: 1,
                demoted: 1
            }
        );
        assert_eq!(wrong.balls, vec![taught(5.0, 0.1)]);
        assert_eq!(wrong.beside, vec![taught(100.0, 0.7)]);
    }

    #[test]
    fn what_the_student_cannot_settle_stays_doubtful() {
        let how = Agreement::default();
        // Two doubts the student is sure of: which is the one ball?
        let both = |_: &BallBox| Some(0.99);
        let mut two = frame(0.0, vec![], vec![taught(5.0, 0.3), taught(200.0, 0.2)]).1;
        assert_eq!(settle(&mut two, &how, both), Settled::default());
        assert!(!two.certain() && two.balls.is_empty());
        // A doubt the student cannot judge (cut by the photo's edge) stays a doubt.
        let mut unjudged = frame(0.0, vec![], vec![taught(5.0, 0.3)]).1;
        assert_eq!(settle(&mut unjudged, &how, |_| None), Settled::default());
        assert!(!unjudged.certain());
        // Several balls a photo: each doubt the student is sure of is a ball.
        let several = Agreement {
            one_ball: false,
            ..how
        };
        let mut many = frame(0.0, vec![], vec![taught(5.0, 0.3), taught(200.0, 0.2)]).1;
        assert_eq!(settle(&mut many, &several, both).promoted, 2);
        assert!(many.certain());
    }

    #[test]
    fn the_teachers_labels_are_held_against_a_persons() {
        let b = |x: f64| taught(x, 0.9).ball_box;
        // Right on the first ball, beside the second, and nothing on the third.
        let a = against(&[b(1.0), b(100.0)], &[b(0.0), b(50.0), b(200.0)]);
        assert_eq!(
            a,
            Against {
                taught: 2,
                right: 1,
                theirs: 3
            }
        );
        // Two boxes on one ball: one is right.
        assert_eq!(against(&[b(1.0), b(2.0)], &[b(0.0)]).right, 1);
    }

    #[test]
    fn neighbours_that_disagree_lend_nothing() {
        let mut frames = vec![
            frame(0.0, vec![taught(0.0, 0.9)], vec![]),
            frame(0.1, vec![], vec![taught(150.0, 0.3)]),
            frame(0.2, vec![taught(300.0, 0.9)], vec![]),
        ];
        assert_eq!(lend_labels(&mut frames, 3), (0, 0));
        assert!(frames[1].1.balls.is_empty());
    }
}

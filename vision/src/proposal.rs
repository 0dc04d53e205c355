//! What the proposal stages give the check: each proposed circle with its stage, and the
//! local views some were found in.

use crate::circle::Circle;
use crate::image::RgbImage;
use proto::CandidateStage;

/// A circle a proposal stage proposes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Proposal {
    /// Centre in the frame; radius in the view's pixels (the frame's scale there).
    pub frame: Circle,
    /// The circle in its local view (or the frame, without a view).
    pub local: Circle,
    /// Index of its local view in [`Proposals::views`].
    pub view: Option<usize>,
    /// Half the angle the ball subtends at the camera, when a camera model was given.
    pub angular_radius_rad: Option<f64>,
    /// The circle came from a sparse blob (a patterned ball's fragments, or a ball partly
    /// hidden): its outline, and so its radius, is less certain than a solid disc's.
    pub sparse_blob: bool,
    /// The stage that proposed it (the colour path, the candidate network, the appearance
    /// proposer or the tracked ball's predicted place).
    pub stage: CandidateStage,
}

/// A frame's proposals and the local views they were found in.
#[derive(Debug, Clone, Default)]
pub struct Proposals {
    pub views: Vec<RgbImage>,
    pub items: Vec<Proposal>,
}

impl Proposals {
    /// The image a proposal's `local` circle refers to.
    pub fn image<'a>(&'a self, p: &Proposal, frame: &'a RgbImage) -> &'a RgbImage {
        p.view.and_then(|i| self.views.get(i)).unwrap_or(frame)
    }
}

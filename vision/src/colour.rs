//! The colour path (the dissertation's, grown): the frame's HSV mask, its cleanup, blobs,
//! the circular Hough transform on local perspective views, and the dominant-colour check.
//!
//! - `hsv`: HSV colour thresholds, the frame's colour mask (exact, or through a lookup
//!   table), and lighting adaptation of the thresholds.
//! - `seeded_mask`: the colour mask grown from the strict window's pixels through a wider
//!   window, decided per image.
//! - `morphology`: mask cleanup by erosion, dilation, opening and closing.
//! - `components`: connected components of a mask with area, bounding box and centroid,
//!   optionally joining fragments a few pixels apart.
//! - `hough`: a circular Hough transform finding ball candidates in a binary mask.
//! - `blob_circle`: circles straight from small or roundish blobs, and masks shrunk for
//!   blobs too big for the Hough transform.
//! - `two_colour`: the two-colour mask of a patterned ball (the ball's colour with white
//!   patches) as one disc.
//! - `kmeans`: the dominant-colour check of a candidate by k-means clustering.
//! - `rectify`: local perspective views of a fisheye frame, where a ball is round (the
//!   Hough transform runs in them).
//! - `propose`: the colour path's proposals of one frame, stages `mask` to `hough`.

pub(crate) mod blob_circle;
pub(crate) mod components;
pub(crate) mod hough;
pub(crate) mod hsv;
pub(crate) mod kmeans;
pub(crate) mod morphology;
pub(crate) mod propose;
pub(crate) mod rectify;
pub(crate) mod seeded_mask;
pub(crate) mod two_colour;

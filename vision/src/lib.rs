//! The robot's vision: one camera frame to ball candidates, one stage per module, with the
//! image buffers and the camera model it looks through. What the robot runs, and nothing
//! else: training is the `lab` crate's (`ball-lab train`), the floor and the world are the
//! agent's pipeline.
//!
//! - [`image`]: RGB, grey and mask images.
//! - [`camera`]: camera models (pinhole, Brown–Conrady, Kannala–Brandt fisheye), projection
//!   and unprojection.
//!
//! - [`hsv`]: HSV colour thresholds, the frame's colour mask (exact, or through a lookup
//!   table), and lighting adaptation of the thresholds.
//! - [`seeded_mask`]: the colour mask grown from the strict window's pixels through a
//!   wider window, decided per image.
//! - [`morphology`]: mask cleanup by erosion, dilation, opening and closing.
//! - [`components`]: connected components of a mask with area, bounding box and centroid,
//!   optionally joining fragments a few pixels apart.
//! - [`hough`]: a circular Hough transform finding ball candidates in a binary mask.
//! - [`blob_circle`]: circles straight from small or roundish blobs, and masks shrunk for
//!   blobs too big for the Hough transform.
//! - [`patch`]: the 32×32 candidate patch around a circle, with mirroring and rotation.
//! - [`hog`]: the histogram-of-oriented-gradients descriptor of a patch (288 features).
//! - [`svm`]: the RBF-kernel SVM candidate filter: its model file and Platt-calibrated
//!   probability (its training is the `lab` crate's).
//! - [`kmeans`]: the dominant-colour check of a candidate by k-means clustering.
//! - [`classifier`]: the colour check and the HOG + SVM filter as one candidate classifier.
//! - [`two_colour`]: the two-colour mask of a patterned ball (the ball's colour with white
//!   patches) as one disc.
//! - [`contrast`]: proposals by appearance, of any colour: compact blobs that stand out
//!   from their surroundings, by centre-surround filters over an image pyramid.
//! - [`ballnet`]: the ball network, a small CNN on a candidate's colour patch giving the
//!   ball's probability and its refined centre and radius, with its own forward pass.
//! - [`nn`]: the forward pass of the detector's small networks (im2col and matrix
//!   products, depthwise convolutions, pooling) and their weights files.
//! - [`heatnet`]: the candidate network, a heatmap of balls over the downscaled frame,
//!   and its peaks as candidates.
//! - [`checker`]: the grey checker, a network on a candidate's 32×32 brightness-normalised
//!   grey patch giving the ball's probability and its refined circle, a batch at a time.
//! - [`detect`]: one frame to ball candidates: the proposals (the colour path's in its own
//!   module, the candidate network's and the appearance proposals), then [`check`].
//! - [`check`]: the proposals judged by the candidate classifier, a view at a time.
//! - [`rectify`]: local perspective views of a fisheye frame, where a ball is round.
//! - [`photo`]: every candidate of one photo on its own (no pose, no projection), with
//!   what became of it, and the photo with the candidates drawn.

pub mod ballnet;
pub mod blob_circle;
pub mod camera;
pub mod check;
pub mod checker;
pub mod classifier;
pub mod components;
pub mod contrast;
pub mod detect;
mod detect_config;
pub mod heatnet;
pub mod hog;
pub mod hough;
pub mod hsv;
pub mod image;
pub mod kmeans;
pub mod morphology;
pub mod nn;
pub mod patch;
#[cfg(any(test, feature = "test-support"))]
pub mod patch_fixtures;
pub mod photo;
pub mod rectify;
pub mod seeded_mask;
pub mod svm;
#[cfg(any(test, feature = "test-support"))]
pub mod test_fixtures;
pub mod two_colour;

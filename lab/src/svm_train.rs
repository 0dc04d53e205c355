//! Training of the RBF-kernel support vector machine that filters ball candidates, with
//! Platt scaling so that its output is a calibrated probability (the detection's
//! confidence).
//!
//! The solver is sequential minimal optimisation on the dual problem
//! `min ½ αᵀQα − Σα` subject to `0 ≤ α ≤ C`, `yᵀα = 0`, `Q_ij = y_i y_j K(x_i, x_j)`,
//! `K(x, z) = exp(−γ‖x − z‖²)`, with the second-order working-set selection of Fan, Chen
//! and Lin (2005) as in libsvm: the first index maximally violates the optimality
//! conditions, the second maximises the guaranteed decrease of the objective. It stops when
//! the largest violation falls below `tolerance`. Kernel rows are computed on demand and
//! kept in a cache bounded in bytes (the whole matrix for the few thousand samples the
//! detector trains on).
//!
//! Features are standardised (zero mean, unit variance per dimension, from the training
//! set) before the kernel is applied, so that γ has the same meaning whatever the
//! features' scales; the mean and scale are stored in the [`Model`].
//!
//! Platt scaling fits `P(ball | f) = 1 / (1 + exp(A f + B))` to decision values `f` that
//! the model did not train on (cross-validated), with the regularised targets and the
//! Newton method of Lin, Lin and Weng (2007).

use serde::{Deserialize, Serialize};

#[cfg(test)]
use proto::rng::SplitMix64;
pub use vision::stages::svm::{Model, Platt, SvmError};
use vision::stages::svm::{Standardiser, dot};

/// Parameters of one SVM fit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SvmParams {
    /// Box constraint C: the cost of a margin violation. Larger fits the training set more
    /// tightly.
    pub c: f64,
    /// RBF width γ, per squared standardised feature unit. Larger makes the boundary more
    /// local.
    pub gamma: f64,
    /// Stopping tolerance on the largest violation of the optimality conditions (libsvm's
    /// 1e-3).
    pub tolerance: f64,
    /// Iteration cap of the solver; reaching it returns the current (usable) solution.
    pub max_iterations: usize,
    /// Memory for cached kernel rows, bytes.
    pub cache_bytes: usize,
}

impl Default for SvmParams {
    fn default() -> Self {
        Self {
            c: 10.0,
            gamma: 1.0 / 288.0,
            tolerance: 1e-3,
            max_iterations: 1_000_000,
            cache_bytes: 256 << 20,
        }
    }
}

impl SvmParams {
    /// Checks that C, γ and the tolerance are finite and positive.
    pub fn check(&self) -> Result<(), SvmError> {
        for (name, value) in [
            ("c", self.c),
            ("gamma", self.gamma),
            ("tolerance", self.tolerance),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(SvmError::BadParameter {
                    name,
                    value,
                    why: "must be finite and positive",
                });
            }
        }
        Ok(())
    }
}

/// Checks features against labels and a common dimension; returns the dimension.
fn check_data<F: AsRef<[f32]>>(features: &[F], labels: &[bool]) -> Result<usize, SvmError> {
    if features.len() != labels.len() {
        return Err(SvmError::LabelCount {
            features: features.len(),
            labels: labels.len(),
        });
    }
    let positives = labels.iter().filter(|&&l| l).count();
    let negatives = labels.len() - positives;
    if positives == 0 || negatives == 0 {
        return Err(SvmError::OneClass {
            positives,
            negatives,
        });
    }
    let dim = features[0].as_ref().len();
    for (index, f) in features.iter().enumerate() {
        let f = f.as_ref();
        if f.len() != dim || dim == 0 {
            return Err(SvmError::Dimension {
                index,
                expected: dim,
                actual: f.len(),
            });
        }
        if f.iter().any(|v| !v.is_finite()) {
            return Err(SvmError::NonFinite { index });
        }
    }
    Ok(dim)
}

/// Kernel rows on demand, cached first-in first-out within a byte budget.
struct KernelCache<'a> {
    x: &'a [f32],
    dim: usize,
    sq_norm: Vec<f32>,
    gamma: f32,
    rows: Vec<Option<Vec<f32>>>,
    order: std::collections::VecDeque<usize>,
    max_rows: usize,
}

impl<'a> KernelCache<'a> {
    fn new(x: &'a [f32], dim: usize, gamma: f64, cache_bytes: usize) -> Self {
        let n = x.len() / dim;
        let sq_norm = x.chunks_exact(dim).map(|r| dot(r, r)).collect();
        let max_rows = (cache_bytes / (4 * n.max(1))).max(2);
        Self {
            x,
            dim,
            sq_norm,
            gamma: gamma as f32,
            rows: vec![None; n],
            order: std::collections::VecDeque::new(),
            max_rows,
        }
    }

    fn row(&mut self, i: usize) -> &[f32] {
        if self.rows[i].is_none() {
            if self.order.len() >= self.max_rows
                && let Some(old) = self.order.pop_front()
            {
                self.rows[old] = None;
            }
            let xi = &self.x[i * self.dim..][..self.dim];
            let row = self
                .x
                .chunks_exact(self.dim)
                .zip(&self.sq_norm)
                .map(|(xj, &nj)| {
                    let d2 = (self.sq_norm[i] + nj - 2.0 * dot(xi, xj)).max(0.0);
                    (-self.gamma * d2).exp()
                })
                .collect();
            self.rows[i] = Some(row);
            self.order.push_back(i);
        }
        self.rows[i].as_deref().unwrap_or(&[])
    }
}

/// The solution of the dual: multipliers and the offset ρ (decision = Σ α y K − ρ).
struct Solution {
    alpha: Vec<f64>,
    rho: f64,
}

/// Second-order working-set selection: `(i, j)`, or `None` when optimal within tolerance.
fn select_working_set(
    y: &[f64],
    alpha: &[f64],
    grad: &[f64],
    c: f64,
    tolerance: f64,
    cache: &mut KernelCache,
) -> Option<(usize, usize)> {
    let in_up = |t: usize| (y[t] > 0.0 && alpha[t] < c) || (y[t] < 0.0 && alpha[t] > 0.0);
    let in_low = |t: usize| (y[t] > 0.0 && alpha[t] > 0.0) || (y[t] < 0.0 && alpha[t] < c);
    let mut g_max = f64::NEG_INFINITY;
    let mut i = usize::MAX;
    for t in 0..y.len() {
        if in_up(t) && -y[t] * grad[t] >= g_max {
            g_max = -y[t] * grad[t];
            i = t;
        }
    }
    if i == usize::MAX {
        return None;
    }
    let row_i = cache.row(i).to_vec();
    let k_ii = f64::from(row_i[i]);
    let mut g_min = f64::INFINITY;
    let mut best = f64::INFINITY;
    let mut j = usize::MAX;
    for t in 0..y.len() {
        if !in_low(t) {
            continue;
        }
        let v = -y[t] * grad[t];
        g_min = g_min.min(v);
        let b = g_max - v;
        if b > 0.0 {
            // K(t, t) = 1 for the RBF kernel.
            let a = (k_ii + 1.0 - 2.0 * f64::from(row_i[t])).max(1e-12);
            let obj = -(b * b) / a;
            if obj <= best {
                best = obj;
                j = t;
            }
        }
    }
    if g_max - g_min < tolerance || j == usize::MAX {
        return None;
    }
    Some((i, j))
}

/// SMO on standardised rows `x` (row-major, `dim` wide) with labels ±1.
fn solve(x: &[f32], dim: usize, y: &[f64], params: &SvmParams) -> Solution {
    let n = y.len();
    let c = params.c;
    let mut alpha = vec![0.0f64; n];
    let mut grad = vec![-1.0f64; n];
    let mut cache = KernelCache::new(x, dim, params.gamma, params.cache_bytes);
    for _ in 0..params.max_iterations {
        let Some((i, j)) = select_working_set(y, &alpha, &grad, c, params.tolerance, &mut cache)
        else {
            break;
        };
        let row_i = cache.row(i).to_vec();
        let row_j = cache.row(j);
        let k_ij = f64::from(row_i[j]);
        let quad = (2.0 - 2.0 * k_ij).max(1e-12);
        let (old_i, old_j) = (alpha[i], alpha[j]);
        if y[i] != y[j] {
            let delta = (-grad[i] - grad[j]) / quad;
            let diff = alpha[i] - alpha[j];
            alpha[i] += delta;
            alpha[j] += delta;
            if diff > 0.0 {
                if alpha[j] < 0.0 {
                    alpha[j] = 0.0;
                    alpha[i] = diff;
                }
            } else if alpha[i] < 0.0 {
                alpha[i] = 0.0;
                alpha[j] = -diff;
            }
            if diff > 0.0 {
                if alpha[i] > c {
                    alpha[i] = c;
                    alpha[j] = c - diff;
                }
            } else if alpha[j] > c {
                alpha[j] = c;
                alpha[i] = c + diff;
            }
        } else {
            let delta = (grad[i] - grad[j]) / quad;
            let sum = alpha[i] + alpha[j];
            alpha[i] -= delta;
            alpha[j] += delta;
            if sum > c {
                if alpha[i] > c {
                    alpha[i] = c;
                    alpha[j] = sum - c;
                }
                if alpha[j] > c {
                    alpha[j] = c;
                    alpha[i] = sum - c;
                }
            } else {
                if alpha[j] < 0.0 {
                    alpha[j] = 0.0;
                    alpha[i] = sum;
                }
                if alpha[i] < 0.0 {
                    alpha[i] = 0.0;
                    alpha[j] = sum;
                }
            }
        }
        let (di, dj) = (alpha[i] - old_i, alpha[j] - old_j);
        for t in 0..n {
            // Q_it = y_i y_t K_it.
            grad[t] += y[t] * (y[i] * di * f64::from(row_i[t]) + y[j] * dj * f64::from(row_j[t]));
        }
    }
    let rho = offset(y, &alpha, &grad, c);
    Solution { alpha, rho }
}

/// The offset ρ: the average of `y G` over free multipliers, or the middle of its feasible
/// interval when none is free (libsvm's rule).
fn offset(y: &[f64], alpha: &[f64], grad: &[f64], c: f64) -> f64 {
    let (mut ub, mut lb) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut sum, mut free) = (0.0, 0usize);
    for t in 0..y.len() {
        let yg = y[t] * grad[t];
        let at_upper = alpha[t] >= c;
        let at_lower = alpha[t] <= 0.0;
        if (at_upper && y[t] < 0.0) || (at_lower && y[t] > 0.0) {
            ub = ub.min(yg);
        } else if at_upper || at_lower {
            lb = lb.max(yg);
        } else {
            sum += yg;
            free += 1;
        }
    }
    if free > 0 {
        sum / free as f64
    } else {
        (ub + lb) / 2.0
    }
}

/// Fits an SVM without calibration: the model's probability uses a default sigmoid
/// (`A = −1, B = 0`) until [`Model::with_platt`] sets a fitted one.
pub fn fit_uncalibrated<F: AsRef<[f32]>>(
    features: &[F],
    labels: &[bool],
    params: &SvmParams,
) -> Result<Model, SvmError> {
    params.check()?;
    let dim = check_data(features, labels)?;
    let standardiser = Standardiser::fit(features, dim);
    let mut x = vec![0.0f32; features.len() * dim];
    for (f, out) in features.iter().zip(x.chunks_exact_mut(dim)) {
        standardiser.apply_into(f.as_ref(), out);
    }
    let y: Vec<f64> = labels.iter().map(|&l| if l { 1.0 } else { -1.0 }).collect();
    let solution = solve(&x, dim, &y, params);
    let mut support = Vec::new();
    let mut coef = Vec::new();
    for (t, &a) in solution.alpha.iter().enumerate() {
        if a > 0.0 {
            support.extend_from_slice(&x[t * dim..][..dim]);
            coef.push((a * y[t]) as f32);
        }
    }
    Model::from_parts(
        dim,
        params.gamma,
        solution.rho,
        standardiser,
        support,
        coef,
        Platt::default(),
    )
}

/// Decision values of each sample from models trained on the other folds (`folds` ≥ 2
/// groups by `fold_of`), for model selection and for fitting Platt scaling.
pub fn cross_val_decisions<F: AsRef<[f32]>>(
    features: &[F],
    labels: &[bool],
    fold_of: &[usize],
    folds: usize,
    params: &SvmParams,
) -> Result<Vec<f64>, SvmError> {
    check_data(features, labels)?;
    if fold_of.len() != labels.len() {
        return Err(SvmError::LabelCount {
            features: fold_of.len(),
            labels: labels.len(),
        });
    }
    let mut out = vec![0.0; labels.len()];
    for fold in 0..folds {
        let train: Vec<usize> = (0..labels.len()).filter(|&t| fold_of[t] != fold).collect();
        let test: Vec<usize> = (0..labels.len()).filter(|&t| fold_of[t] == fold).collect();
        if test.is_empty() {
            continue;
        }
        let tf: Vec<&[f32]> = train.iter().map(|&t| features[t].as_ref()).collect();
        let tl: Vec<bool> = train.iter().map(|&t| labels[t]).collect();
        let model = fit_uncalibrated(&tf, &tl, params)?;
        for &t in &test {
            out[t] = model.decision(features[t].as_ref())?;
        }
    }
    Ok(out)
}

/// Fits a calibrated SVM: Platt scaling on `folds`-fold cross-validated decision values
/// (folds drawn with `seed`), then the SVM on all samples.
#[cfg(test)]
pub fn fit<F: AsRef<[f32]>>(
    features: &[F],
    labels: &[bool],
    params: &SvmParams,
    folds: usize,
    seed: u64,
) -> Result<Model, SvmError> {
    check_data(features, labels)?;
    let folds = folds.max(2);
    let mut fold_of: Vec<usize> = (0..labels.len()).map(|t| t % folds).collect();
    SplitMix64::new(seed).shuffle(&mut fold_of);
    let decisions = cross_val_decisions(features, labels, &fold_of, folds, params)?;
    let platt = Platt::fit(&decisions, labels)?;
    Ok(fit_uncalibrated(features, labels, params)?.with_platt(platt))
}

#[cfg(test)]
#[path = "svm_train_tests.rs"]
mod tests;

//! The condensed sliding-contact problem and its two solvers.
//!
//! On the contact pairs, with every closed pair sliding (r_t = μ r_n, r_b = 0), the normal
//! gaps depend linearly on the normal reactions through the condensed operator
//! W = H K⁻¹ Hᵀ:  g = q + A r,  A = W_nn + μ W_nt,  q = g₀ + (H K⁻¹ F)_n.
//! Signorini's law is then the linear complementarity problem
//!
//! ```text
//! r ≥ 0,   g = q + A r ≥ 0,   rᵀ g = 0
//! ```
//!
//! With floating bodies (pads pressed by a pressure, free along the normal) the gaps also
//! depend on the amplitudes a of their zero-energy motions, and the reactions must balance
//! the load on each such body ([`Balance`]): the mixed problem
//!
//! ```text
//! r ≥ 0,   g = q + A r + B a ≥ 0,   rᵀ g = 0,   Cᵀ r = d      (a free)
//! ```
//!
//! - [`fixed_point`]: the augmented-Lagrangian iteration of Loyer et al. (2011)
//!   r ← proj_{R+}(r − ρ ∘ g(r)) with ρᵢ = ω / Aᵢᵢ (the diagonal approximation of the
//!   condensed operator for the augmentation parameters). With a balance, a is chosen at
//!   each sweep so that the updated reactions balance the load exactly: with
//!   w = r − ρ ∘ (q + A r) and P the pairs the update leaves closed,
//!   (C_Pᵀ D_ρ B_P) a = C_Pᵀ w_P − d (an m × m system, m the number of rigid motions), then
//!   r ← proj_{R+}(w − ρ ∘ B a). P is re-evaluated with the new a until it repeats. A fixed
//!   point of the sweep is a solution: r = proj(r − ρ g) is complementarity, and the
//!   reactions balance whenever P is the closed set. Like the plain Jacobi sweep, it needs
//!   under-relaxation (ω = 0.5) when the pairs of a pad are strongly coupled: with ω = 1 a
//!   soft pad block (all its pairs moving together) stalls in a cycle, and the solver then
//!   fails with its residual history.
//! - [`semismooth_newton`]: a primal–dual active-set (semi-smooth Newton) method on
//!   min(r, c g) = 0: guess the closed set C, solve A_CC r_C = −q_C, update, until the set
//!   repeats. With a balance the step is the bordered system
//!   `[A_CC B_C; C_Cᵀ 0] [r_C; a] = [−q_C; d]`, starting from every pair closed (pads pressed
//!   onto the disc). It ends in a few iterations where the fixed point needs hundreds.
//!
//! Both report the complementarity residual ‖min(r, g/ρ̄)‖∞ scaled by the largest reaction
//! (and, with a balance, the larger of it and the relative balance error ‖Cᵀ r − d‖∞), and
//! fail loudly with their residual history.

use faer::Mat;
use faer::linalg::solvers::Solve;

/// A solution of the condensed problem.
#[derive(Debug, Clone, PartialEq)]
pub struct LcpSolution {
    /// Normal reactions (≥ 0: compression).
    pub r: Vec<f64>,
    /// Normal gaps (≥ 0: open).
    pub g: Vec<f64>,
    /// Amplitudes of the floating bodies' rigid motions (empty without a [`Balance`]).
    pub a: Vec<f64>,
    pub iterations: usize,
    /// Residual after each iteration.
    pub history: Vec<f64>,
}

impl LcpSolution {
    pub fn residual(&self) -> f64 {
        self.history.last().copied().unwrap_or(f64::INFINITY)
    }
}

/// Why a solver gave up, with the residual history.
#[derive(Debug, Clone, PartialEq)]
pub struct LcpError {
    pub solver: &'static str,
    pub iterations: usize,
    pub history: Vec<f64>,
    pub tolerance: f64,
    /// The first pair whose diagonal `A_ii` is not positive (or NaN), when that is why the
    /// solver could not start.
    pub non_positive_diagonal: Option<(usize, f64)>,
    /// The period of the active sets' cycle, when the active-set iteration came back to a set
    /// it had left.
    pub cycle: Option<usize>,
}

impl std::fmt::Display for LcpError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some((pair, value)) = self.non_positive_diagonal {
            return write!(
                f,
                "{} cannot start: the condensed sliding-contact operator A = W_nn + mu W_nt has A[{pair},{pair}] = {value:.3e} <= 0 at pair {pair}: pressing that pair in opens it (the friction term outweighs the normal stiffness), so the sliding equilibrium is not unique, or does not exist, at this friction coefficient; lower mu",
                self.solver
            );
        }
        if let Some(period) = self.cycle {
            return write!(
                f,
                "{} cycles through {period} sets of closed pairs after {} iterations (complementarity residual {:.3e}): at this friction coefficient the condensed sliding-contact operator A = W_nn + mu W_nt does not make the contact problem uniquely solvable; lower mu",
                self.solver,
                self.iterations,
                self.history.last().copied().unwrap_or(f64::NAN)
            );
        }
        let shown: Vec<String> = self
            .history
            .iter()
            .rev()
            .take(5)
            .rev()
            .map(|value| format!("{value:.3e}"))
            .collect();
        write!(
            f,
            "{} did not converge in {} iterations: complementarity residual {:.3e} > {:.1e} (last residuals: {})",
            self.solver,
            self.iterations,
            self.history.last().copied().unwrap_or(f64::NAN),
            self.tolerance,
            shown.join(", ")
        )
    }
}

/// Settings shared by both solvers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LcpSettings {
    pub tolerance: f64,
    pub max_iterations: usize,
    /// Relaxation ω of the fixed point's augmentation parameters ρᵢ = ω / Aᵢᵢ.
    pub relaxation: f64,
}

impl Default for LcpSettings {
    fn default() -> Self {
        LcpSettings {
            tolerance: 1e-10,
            max_iterations: 10_000,
            relaxation: 1.0,
        }
    }
}

/// The rigid motions of floating bodies in the contact problem: their amplitudes a shift the
/// gaps by B a, and the reactions must balance the load on each body, Cᵀ r = d.
/// `B`, `C` are pairs × m, `d` has m entries (m = 0: the plain LCP).
#[derive(Debug, Clone, PartialEq)]
pub struct Balance {
    pub B: Mat<f64>,
    pub C: Mat<f64>,
    pub d: Vec<f64>,
}

impl Balance {
    /// No floating body: the plain LCP.
    pub fn none(n_pairs: usize) -> Balance {
        Balance {
            B: Mat::zeros(n_pairs, 0),
            C: Mat::zeros(n_pairs, 0),
            d: Vec::new(),
        }
    }

    fn n_motions(&self) -> usize {
        self.d.len()
    }

    /// ‖Cᵀ r − d‖∞ / max(‖d‖∞, max_j Σᵢ |Cᵢⱼ rᵢ|): the relative out-of-balance force.
    pub fn residual(&self, r: &[f64]) -> f64 {
        let mut worst = 0.0f64;
        let mut scale = f64::MIN_POSITIVE;
        for (j, d) in self.d.iter().enumerate() {
            let (mut sum, mut magnitude) = (0.0, 0.0);
            for (i, r) in r.iter().enumerate() {
                sum += self.C[(i, j)] * r;
                magnitude += (self.C[(i, j)] * r).abs();
            }
            worst = worst.max((sum - d).abs());
            scale = scale.max(d.abs()).max(magnitude);
        }
        worst / scale
    }
}

fn gaps(a: &Mat<f64>, q: &[f64], r: &[f64], balance: &Balance, amplitudes: &[f64]) -> Vec<f64> {
    (0..q.len())
        .map(|i| {
            q[i] + (0..r.len()).map(|j| a[(i, j)] * r[j]).sum::<f64>()
                + (0..amplitudes.len())
                    .map(|j| balance.B[(i, j)] * amplitudes[j])
                    .sum::<f64>()
        })
        .collect()
}

/// ‖min(r, Aᵢᵢ g)‖∞ / max(‖r‖∞, ‖Aᵢᵢ q‖∞): zero exactly at a solution, in units of force.
pub fn complementarity_residual(a: &Mat<f64>, q: &[f64], r: &[f64], g: &[f64]) -> f64 {
    let force = |i: usize, gap: f64| gap / a[(i, i)];
    let scale = (0..q.len())
        .map(|i| r[i].abs().max(force(i, q[i]).abs()))
        .fold(f64::MIN_POSITIVE, f64::max);
    let worst = (0..q.len())
        .map(|i| r[i].min(force(i, g[i])).abs())
        .fold(0.0, f64::max);
    worst / scale
}

/// The residual both solvers stop on: complementarity, and the balance when there is one.
fn residual(a: &Mat<f64>, q: &[f64], r: &[f64], g: &[f64], balance: &Balance) -> f64 {
    let complementarity = complementarity_residual(a, q, r, g);
    if balance.n_motions() == 0 {
        complementarity
    } else {
        complementarity.max(balance.residual(r))
    }
}

fn check_diagonal(a: &Mat<f64>, solver: &'static str) -> Result<(), LcpError> {
    // A non-positive (or NaN) diagonal leaves the augmentation parameters undefined, and
    // means the problem has lost the uniqueness a P-matrix gives.
    match (0..a.nrows()).find(|&i| a[(i, i)].is_nan() || a[(i, i)] <= 0.0) {
        Some(pair) => Err(LcpError {
            solver,
            iterations: 0,
            history: Vec::new(),
            tolerance: 0.0,
            non_positive_diagonal: Some((pair, a[(pair, pair)])),
            cycle: None,
        }),
        None => Ok(()),
    }
}

/// The projected fixed point of Loyer et al. (2011), in Jacobi form.
pub fn fixed_point(
    a: &Mat<f64>,
    q: &[f64],
    settings: &LcpSettings,
) -> Result<LcpSolution, LcpError> {
    fixed_point_balanced(a, q, &Balance::none(q.len()), settings)
}

/// Amplitudes a with Σ_{i∈P} Cᵢⱼ (wᵢ − ρᵢ (B a)ᵢ) = dⱼ: the reactions of the pairs in P after
/// the sweep balance the load.
fn balancing_amplitudes(w: &[f64], rho: &[f64], closed: &[bool], balance: &Balance) -> Vec<f64> {
    let m = balance.n_motions();
    let system = Mat::from_fn(m, m, |j, k| {
        (0..w.len())
            .filter(|&i| closed[i])
            .map(|i| balance.C[(i, j)] * rho[i] * balance.B[(i, k)])
            .sum::<f64>()
    });
    let rhs = Mat::from_fn(m, 1, |j, _| {
        (0..w.len())
            .filter(|&i| closed[i])
            .map(|i| balance.C[(i, j)] * w[i])
            .sum::<f64>()
            - balance.d[j]
    });
    let solution = system.partial_piv_lu().solve(&rhs);
    (0..m).map(|j| solution[(j, 0)]).collect()
}

/// [`fixed_point`] with the rigid motions and balance of floating bodies (module docs).
pub fn fixed_point_balanced(
    a: &Mat<f64>,
    q: &[f64],
    balance: &Balance,
    settings: &LcpSettings,
) -> Result<LcpSolution, LcpError> {
    const SOLVER: &str = "fixed point";
    check_diagonal(a, SOLVER)?;
    let n = q.len();
    let m = balance.n_motions();
    let rho: Vec<f64> = (0..n).map(|i| settings.relaxation / a[(i, i)]).collect();
    let mut r = vec![0.0; n];
    let mut amplitudes = vec![0.0; m];
    // Pads pressed onto the disc: every pair closed to start with.
    let mut closed = vec![true; n];
    let mut history = Vec::new();
    for iteration in 1..=settings.max_iterations {
        let g = gaps(a, q, &r, balance, &amplitudes);
        if m == 0 {
            for i in 0..n {
                r[i] = (r[i] - rho[i] * g[i]).max(0.0);
            }
        } else {
            // w = r − ρ ∘ (q + A r): the sweep without the rigid motions.
            let w: Vec<f64> = (0..n)
                .map(|i| r[i] - rho[i] * (g[i] - shift(balance, &amplitudes, i)))
                .collect();
            // Closed set and amplitudes consistent with each other (at most n + 1 passes:
            // each pass that changes the set is followed by a recomputation).
            for _ in 0..=n {
                amplitudes = balancing_amplitudes(&w, &rho, &closed, balance);
                let updated: Vec<bool> = (0..n)
                    .map(|i| w[i] - rho[i] * shift(balance, &amplitudes, i) > 0.0)
                    .collect();
                if updated == closed || !updated.iter().any(|closed| *closed) {
                    break;
                }
                closed = updated;
            }
            for i in 0..n {
                r[i] = (w[i] - rho[i] * shift(balance, &amplitudes, i)).max(0.0);
            }
        }
        let g = gaps(a, q, &r, balance, &amplitudes);
        let residual = residual(a, q, &r, &g, balance);
        history.push(residual);
        if residual <= settings.tolerance {
            return Ok(LcpSolution {
                r,
                g,
                a: amplitudes,
                iterations: iteration,
                history,
            });
        }
        if !residual.is_finite() {
            break;
        }
    }
    Err(LcpError {
        solver: SOLVER,
        iterations: history.len(),
        history,
        tolerance: settings.tolerance,
        non_positive_diagonal: None,
        cycle: None,
    })
}

/// (B a)ᵢ.
fn shift(balance: &Balance, amplitudes: &[f64], i: usize) -> f64 {
    amplitudes
        .iter()
        .enumerate()
        .map(|(j, a)| balance.B[(i, j)] * a)
        .sum()
}

/// Primal–dual active set (semi-smooth Newton on min(r, c g) = 0, c = 1/mean Aᵢᵢ).
pub fn semismooth_newton(
    a: &Mat<f64>,
    q: &[f64],
    settings: &LcpSettings,
) -> Result<LcpSolution, LcpError> {
    semismooth_newton_balanced(a, q, &Balance::none(q.len()), settings)
}

/// [`semismooth_newton`] with the rigid motions and balance of floating bodies: each step
/// solves the bordered system `[A_CC B_C; C_Cᵀ 0] [r_C; a] = [−q_C; d]`.
pub fn semismooth_newton_balanced(
    a: &Mat<f64>,
    q: &[f64],
    balance: &Balance,
    settings: &LcpSettings,
) -> Result<LcpSolution, LcpError> {
    const SOLVER: &str = "semi-smooth Newton";
    check_diagonal(a, SOLVER)?;
    let n = q.len();
    let m = balance.n_motions();
    let mut r = vec![0.0; n];
    let mut amplitudes = vec![0.0; m];
    let mut g = q.to_vec();
    let mut history = Vec::new();
    let mut visited: Vec<Vec<bool>> = Vec::new();
    let mut cycle = None;
    for iteration in 1..=settings.max_iterations.min(20 * n.max(1)) {
        // A pair is closed when its reaction, or the force its penetration would take, is
        // positive. Floating pads start pressed onto the disc: every pair closed.
        let closed: Vec<bool> = if m > 0 && iteration == 1 {
            vec![true; n]
        } else {
            (0..n).map(|i| r[i] - g[i] / a[(i, i)] > 0.0).collect()
        };
        let indices: Vec<usize> = (0..n).filter(|&i| closed[i]).collect();
        let k = indices.len();
        r = vec![0.0; n];
        if k + m > 0 {
            let block = Mat::from_fn(k + m, k + m, |row, col| match (row < k, col < k) {
                (true, true) => a[(indices[row], indices[col])],
                (true, false) => balance.B[(indices[row], col - k)],
                (false, true) => balance.C[(indices[col], row - k)],
                (false, false) => 0.0,
            });
            let rhs = Mat::from_fn(k + m, 1, |row, _| {
                if row < k {
                    -q[indices[row]]
                } else {
                    balance.d[row - k]
                }
            });
            let solution = block.partial_piv_lu().solve(&rhs);
            for (row, &i) in indices.iter().enumerate() {
                r[i] = solution[(row, 0)];
            }
            amplitudes = (0..m).map(|j| solution[(k + j, 0)]).collect();
        }
        g = gaps(a, q, &r, balance, &amplitudes);
        let residual = residual(a, q, &r, &g, balance);
        history.push(residual);
        if residual <= settings.tolerance {
            return Ok(LcpSolution {
                r,
                g,
                a: amplitudes,
                iterations: iteration,
                history,
            });
        }
        // A closed set seen before without convergence: the iteration stalls (period 1) or
        // cycles.
        if let Some(seen) = visited.iter().position(|set| *set == closed) {
            let period = visited.len() - seen;
            cycle = (period > 1).then_some(period);
            break;
        }
        if !residual.is_finite() {
            break;
        }
        visited.push(closed);
    }
    Err(LcpError {
        solver: SOLVER,
        iterations: history.len(),
        history,
        tolerance: settings.tolerance,
        non_positive_diagonal: None,
        cycle,
    })
}

#[cfg(test)]
mod tests;

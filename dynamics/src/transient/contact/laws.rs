//! The laws of contact and friction on every pair, and the problem of one step.
//!
//! The iterative solvers iterate the projection form of the laws, for any ρ > 0,
//!
//! ```text
//! r_n ← max(0, r_n − ρ_n (w_n − w_n,min)),    r_T ← proj_{‖·‖ ≤ μ r_n}(r_T − ρ_T s)
//! ```
//!
//! with `ρ` from the diagonal of `W` (`ρ_n = 1/W_nn`, `ρ_T = 1/max(W_tt, W_bb)` per pair: one
//! length for both tangential directions keeps the disk projection isotropic), whose
//! fixed points are exactly the solutions.
//!
//! Convergence is measured by the natural residual `max_p ‖r_p − proj(r_p)‖ / R`, `R` the
//! force scale (the largest equilibrium reaction, or the largest reaction found).

use std::ops::Range;

use serde::{Deserialize, Serialize};

use super::delassus::{Delassus, Step};

crate::choice! {
    /// The contact solver, by the name the transient's `solver` parameter gives it.
    pub enum Solver {
        ActiveSet = "active_set",
        GaussSeidel = "gauss_seidel",
        FixedPoint = "fixed_point",
    }
}

/// Contact state of a pair at the end of a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum PairState {
    Open,
    Stick,
    Slide,
}

/// Open (no reaction), sticking (no slip) or sliding, from the end-of-step reaction and
/// velocity; a slip below 1e-9 of the sliding speed, or of `speed_scale` where that is larger
/// (a surface at rest), counts as sticking.
pub fn classify(r: &[f64], w: &[f64], p: usize, sliding_speed: f64, speed_scale: f64) -> PairState {
    if r[3 * p] <= 0.0 {
        return PairState::Open;
    }
    if slip(w, p, sliding_speed).0 <= 1e-9 * sliding_speed.max(speed_scale) {
        PairState::Stick
    } else {
        PairState::Slide
    }
}

/// The slip speed `‖s‖` of pair `p` and the friction direction `d = −s/‖s‖` (zero without slip).
pub(super) fn slip(w: &[f64], p: usize, sliding_speed: f64) -> (f64, [f64; 2]) {
    let s = [w[3 * p + 1] - sliding_speed, w[3 * p + 2]];
    let length = norm(s);
    if length > 0.0 {
        (length, [-s[0] / length, -s[1] / length])
    } else {
        (0.0, [0.0; 2])
    }
}

/// The data of one step's problem.
pub struct Problem<'a> {
    /// The Delassus operator.
    pub W: &'a Delassus,
    /// End-of-step relative velocities without reaction.
    pub w_free: &'a [f64],
    /// Least normal relative velocity per pair, `−B̃/τ`.
    pub w_n_min: &'a [f64],
    /// Sliding speed `|v_g|` of the disc per pair.
    pub sliding_speed: &'a [f64],
    /// The speed below whose 1e-9 a slip counts as none ([`classify`]; 0: the sliding speed).
    pub speed_scale: f64,
    /// Friction coefficient per pair: the kinetic one, or the static one for a pair that
    /// stuck at the step's start.
    pub mu: &'a [f64],
    /// Force scale of the residual (N).
    pub force_scale: f64,
    /// The pairs in the order Gauss–Seidel sweeps them, in blocks of consecutive pairs
    /// (those of one pad: [`pad_blocks`](super::pad_blocks)), each block's own problem swept a few times before
    /// the rest of `w` is brought up to date.
    pub blocks: &'a [Range<usize>],
}

impl Problem<'_> {
    pub(super) fn n_pairs(&self) -> usize {
        self.w_n_min.len()
    }

    pub(super) fn step_lengths(&self) -> &Step {
        &self.W.step
    }

    /// The projection of the laws for pair `p` at reaction `r` and velocities `w`.
    pub(super) fn project(&self, p: usize, r: [f64; 3], w: [f64; 3]) -> [f64; 3] {
        let step = self.step_lengths();
        let r_n = (r[0] - step.rho_n[p] * (w[0] - self.w_n_min[p])).max(0.0);
        let slip = [w[1] - self.sliding_speed[p], w[2]];
        let trial = [
            r[1] - step.rho_T[p] * slip[0],
            r[2] - step.rho_T[p] * slip[1],
        ];
        let radius = self.mu[p] * r_n;
        let length = norm(trial);
        let scale = if length > radius {
            radius / length
        } else {
            1.0
        };
        [r_n, trial[0] * scale, trial[1] * scale]
    }

    pub(super) fn residual(&self, r: &[f64], w: &[f64]) -> f64 {
        let mut worst: f64 = 0.0;
        let mut largest: f64 = 0.0;
        for p in 0..self.n_pairs() {
            let r_p = pair(r, p);
            let projected = self.project(p, r_p, pair(w, p));
            let change = (0..3)
                .map(|d| (projected[d] - r_p[d]).abs())
                .fold(0.0, f64::max);
            worst = worst.max(change);
            largest = largest
                .max(r_p[0].abs())
                .max(r_p[1].abs())
                .max(r_p[2].abs());
        }
        let scale = self.force_scale.max(largest);
        if scale > 0.0 { worst / scale } else { 0.0 }
    }
}

/// The length of a tangential vector. (`hypot`'s guard against overflow is a library call in
/// the innermost loop, and forces and velocities here are nowhere near 1e154.)
fn norm(x: [f64; 2]) -> f64 {
    (x[0] * x[0] + x[1] * x[1]).sqrt()
}

pub fn pair(values: &[f64], p: usize) -> [f64; 3] {
    [values[3 * p], values[3 * p + 1], values[3 * p + 2]]
}

//! The iterative solvers, on the projection form of the laws (`laws.rs`):
//! - [`Solver::FixedPoint`](super::Solver::FixedPoint), the classic algorithm of the method:
//!   every pair at once from the previous iterate (a Jacobi sweep), `w = w_free + W r` once
//!   per iteration;
//! - [`Solver::GaussSeidel`](super::Solver::GaussSeidel) (projected Gauss–Seidel): pair after
//!   pair, each using the reactions already updated in the sweep, projected once per sweep,
//!   `w` kept current by rank-3 updates. It needs fewer sweeps and does not depend on
//!   diagonal dominance of `W` to converge, but it converges linearly, at a rate set by the
//!   coupling of neighbouring pairs through `W`. Neighbours on one pad couple through its
//!   compliance far more than through the disc, so a sweep goes pad by pad
//!   ([`pad_blocks`]): a pad's pairs are swept several times against the pad's own square of
//!   `W` (in cache), keeping only its rows of `w` current, before its change of reactions
//!   updates the rest of `w` in one pass over its columns. Every pair update is still an
//!   exact Gauss–Seidel update (no other pair moves meanwhile), and the passes over the
//!   whole of `W` drop severalfold. The sweeps are accelerated by Anderson mixing
//!   (`anderson.rs`).

use std::ops::Range;

use super::anderson::Anderson;
use super::delassus::{Precision, column, velocities};
use super::laws::{Problem, pair};
use super::{NotConverged, Report};

/// Residuals kept for an error message.
const HISTORY_KEPT: usize = 12;

/// Solves the step's problem with an iterative solver from the reactions `r` (a warm start,
/// overwritten with the solution), `w` its velocities on entry, the solution's on return.
pub(super) fn iterate(
    problem: &Problem,
    gauss_seidel: bool,
    precision: Precision,
    tolerance: f64,
    max_iterations: usize,
    r: &mut [f64],
    w: &mut [f64],
) -> Result<Report, NotConverged> {
    let mut history = Vec::new();
    let mut next = vec![0.0; r.len()];
    let mut anderson = Anderson::new(r.len());
    for iteration in 1..=max_iterations {
        if gauss_seidel {
            anderson.start(r);
            gauss_seidel_sweep(problem, precision, r, w);
        } else {
            for p in 0..problem.n_pairs() {
                let projected = problem.project(p, pair(r, p), pair(w, p));
                next[3 * p..3 * p + 3].copy_from_slice(&projected);
            }
            r.copy_from_slice(&next);
            velocities(problem.W, problem.w_free, r, w);
        }
        let residual = problem.residual(r, w);
        history.push(residual);
        if history.len() > HISTORY_KEPT {
            history.remove(0);
        }
        if residual <= tolerance {
            return Ok(Report {
                iterations: iteration,
                residual,
                precision,
            });
        }
        if !residual.is_finite() {
            break;
        }
        if gauss_seidel {
            anderson.mix(r, w);
        }
    }
    Err(NotConverged {
        iterations: max_iterations,
        history,
    })
}

/// Sweeps over one block's own pairs before the rest of `w` is brought up to date.
const BLOCK_SWEEPS: usize = 8;
/// The most pairs in one Gauss–Seidel block: a block's own sweeps read its square of `W`, to
/// stay in cache.
pub(super) const LARGEST_BLOCK: usize = 32;

/// Gauss–Seidel blocks for pairs pressing the bodies `body_of_pair` (any labels): runs of
/// consecutive pairs on one body, at most `LARGEST_BLOCK` pairs each.
pub fn pad_blocks(body_of_pair: &[usize]) -> Vec<Range<usize>> {
    let mut blocks: Vec<Range<usize>> = Vec::new();
    for (p, body) in body_of_pair.iter().enumerate() {
        match blocks.last_mut() {
            Some(block) if body_of_pair[block.start] == *body && block.len() < LARGEST_BLOCK => {
                block.end = p + 1
            }
            _ => blocks.push(p..p + 1),
        }
    }
    blocks
}

squeal_linalg::widest_vectors! {
    /// One Gauss–Seidel sweep over the pairs, block by block; `w` is kept equal to
    /// `w_free + W r`. Within a block, [`BLOCK_SWEEPS`] sweeps over its pairs keep only the
    /// block's own rows of `w` current (each pair's update is still exact: no other pair
    /// moves meanwhile); then the block's change of `r` updates every row.
    fn gauss_seidel_sweep(
        problem: &Problem,
        precision: Precision,
        r: &mut [f64],
        w: &mut [f64],
    ) {
        let W = problem.W.double.as_ref();
        for pairs in problem.blocks {
            let rows = 3 * pairs.start..3 * pairs.end;
            let (r_start, w_start) = (r[rows.clone()].to_vec(), w[rows.clone()].to_vec());
            let sweeps = if pairs.len() == 1 { 1 } else { BLOCK_SWEEPS };
            for _ in 0..sweeps {
                for p in pairs.clone() {
                    let k = 3 * p;
                    let start = pair(r, p);
                    let r_p = problem.project(p, start, pair(w, p));
                    let delta = [r_p[0] - start[0], r_p[1] - start[1], r_p[2] - start[2]];
                    if delta != [0.0; 3] {
                        let columns = [k, k + 1, k + 2].map(|k| &column(W, k)[rows.clone()]);
                        for (row, slot) in w[rows.clone()].iter_mut().enumerate() {
                            *slot += columns[0][row] * delta[0]
                                + columns[1][row] * delta[1]
                                + columns[2][row] * delta[2];
                        }
                        r[k..k + 3].copy_from_slice(&r_p);
                    }
                }
            }
            w[rows.clone()].copy_from_slice(&w_start);
            for (k, before) in rows.zip(r_start) {
                let change = r[k] - before;
                if change != 0.0 {
                    problem.W.add_column(k, change, w, precision);
                }
            }
        }
    }
}

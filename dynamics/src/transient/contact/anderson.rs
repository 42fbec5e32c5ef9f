//! Anderson mixing of the Gauss–Seidel sweeps.

use std::collections::VecDeque;

use squeal_linalg::kernels::{axpy, dot};

/// Past sweeps an Anderson step combines.
const ANDERSON_DEPTH: usize = 5;

/// Anderson acceleration of the Gauss–Seidel sweeps `g = G(x)` (type II): with `f = g − x`
/// each sweep's change, and `ΔF`, `ΔG` the differences of the last few sweeps' `f` and `g`,
/// the next sweep starts from
///
/// ```text
/// x⁺ = g_k − ΔG γ,    γ = argmin ‖f_k − ΔF γ‖
/// ```
///
/// the combination of the past sweeps that would have changed least, were `G` affine (it is,
/// while the pairs keep their states). `w` is affine in `r`, so `x⁺`'s velocities are the
/// same combination of the sweeps' (`w(g_k) − ΔW γ`): no pass over `W`.
pub(super) struct Anderson {
    /// The sweep's input `x` (kept by [`Anderson::start`]).
    input: Vec<f64>,
    /// The last sweep's `f`, `g` and `w(g)`, once there is one.
    last: Option<[Vec<f64>; 3]>,
    /// The differences `ΔF`, `ΔG`, `ΔW` of the last [`ANDERSON_DEPTH`] sweeps, oldest first.
    differences: VecDeque<[Vec<f64>; 3]>,
}

impl Anderson {
    pub(super) fn new(n: usize) -> Anderson {
        Anderson {
            input: vec![0.0; n],
            last: None,
            differences: VecDeque::with_capacity(ANDERSON_DEPTH),
        }
    }

    /// Keeps the input of the sweep about to run.
    pub(super) fn start(&mut self, r: &[f64]) {
        self.input.copy_from_slice(r);
    }

    /// Takes the sweep's output `(r, w) = (g_k, w(g_k))` and replaces it with the next input.
    pub(super) fn mix(&mut self, r: &mut [f64], w: &mut [f64]) {
        let f: Vec<f64> = r.iter().zip(&self.input).map(|(g, x)| g - x).collect();
        let Some(last) = self.last.replace([f, r.to_vec(), w.to_vec()]) else {
            return;
        };
        let current = self.last.as_ref().expect("just kept");
        if self.differences.len() == ANDERSON_DEPTH {
            self.differences.pop_front();
        }
        self.differences.push_back(std::array::from_fn(|which| {
            current[which]
                .iter()
                .zip(&last[which])
                .map(|(new, old)| new - old)
                .collect()
        }));
        // The normal equations of min ‖f_k − ΔF γ‖.
        let m = self.differences.len();
        let dF = |i: usize| &self.differences[i][0];
        let mut gram: Vec<f64> = (0..m * m)
            .map(|k| dot(dF((k / m).min(k % m)), dF((k / m).max(k % m))))
            .collect();
        let mut rhs: Vec<f64> = (0..m).map(|i| dot(dF(i), &current[0])).collect();
        let Some(gamma) = solve_small(&mut gram, &mut rhs, m) else {
            self.differences.clear();
            return;
        };
        for (g, difference) in gamma.iter().zip(&self.differences) {
            axpy(-g, &difference[1], r);
            axpy(-g, &difference[2], w);
        }
    }
}

/// `A γ = b` for a small symmetric positive semi-definite `A` (row-major `m × m`), by
/// Cholesky with a relative shift; `None` if it is singular to rounding.
fn solve_small(A: &mut [f64], b: &mut [f64], m: usize) -> Option<Vec<f64>> {
    let trace: f64 = (0..m).map(|i| A[i * m + i]).sum();
    if !(trace > 0.0) {
        return None;
    }
    for i in 0..m {
        A[i * m + i] += 1e-12 * trace;
    }
    for j in 0..m {
        let mut d = A[j * m + j];
        for k in 0..j {
            d -= A[j * m + k] * A[j * m + k];
        }
        if !(d > 0.0) {
            return None;
        }
        let d = d.sqrt();
        A[j * m + j] = d;
        for i in j + 1..m {
            let mut v = A[i * m + j];
            for k in 0..j {
                v -= A[i * m + k] * A[j * m + k];
            }
            A[i * m + j] = v / d;
        }
    }
    for i in 0..m {
        for k in 0..i {
            b[i] -= A[i * m + k] * b[k];
        }
        b[i] /= A[i * m + i];
    }
    for i in (0..m).rev() {
        for k in i + 1..m {
            b[i] -= A[k * m + i] * b[k];
        }
        b[i] /= A[i * m + i];
    }
    Some(b.to_vec())
}

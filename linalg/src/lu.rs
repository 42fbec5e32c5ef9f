//! A dense LU factorisation `P A = L U` (partial pivoting, faer's) kept for solves of one
//! vector at a time.
//!
//! The factors are packed into one column-major array, `L` strictly below the diagonal (its
//! unit diagonal implied) and `U` on and above it, so that each sweep reads each column once,
//! contiguously:
//!
//! ```text
//! forward   (L y = P b):  y_j = b_j,          b_{j+1..n} −= L_{j+1..n, j} y_j
//! backward  (U x = y):    x_j = y_j / U_jj,   y_{0..j}   −= U_{0..j, j} x_j
//! ```
//!
//! one `axpy` per column on the widest vector unit. faer's solve of a single vector (blocked,
//! with a scratch allocation per call) read an 864-unknown single-precision factor at about a
//! third of that rate, and the transient's contact solver does such a solve at every chord
//! iteration. Every sum's order is fixed by the factors: the result does not depend on the
//! thread count.

use faer::MatRef;
use faer::linalg::solvers::PartialPivLu;

/// `P A = L U` of a square matrix, packed for one-vector solves.
#[derive(Debug, Clone)]
pub struct PackedLu {
    n: usize,
    /// `L` strictly below the diagonal, `U` on and above it, column-major.
    factors: Vec<f32>,
    /// Row `i` of `P b` is `b[rows[i]]`.
    rows: Vec<usize>,
}

impl PackedLu {
    /// Factorises the square `A`.
    pub fn new(A: MatRef<'_, f32>) -> PackedLu {
        assert_eq!(
            A.nrows(),
            A.ncols(),
            "an LU factorisation needs a square matrix"
        );
        let n = A.nrows();
        let lu = PartialPivLu::new(A);
        let (L, U) = (lu.L(), lu.U());
        let factors = (0..n)
            .flat_map(|j| (0..n).map(move |i| if i > j { L[(i, j)] } else { U[(i, j)] }))
            .collect();
        PackedLu {
            n,
            factors,
            rows: lu.P().arrays().0.to_vec(),
        }
    }

    /// Unknowns.
    pub fn n(&self) -> usize {
        self.n
    }

    /// `b ← A⁻¹ b`.
    pub fn solve_in_place(&self, b: &mut [f32]) {
        assert_eq!(
            b.len(),
            self.n,
            "the right-hand side has one entry per unknown"
        );
        let mut y: Vec<f32> = self.rows.iter().map(|&row| b[row]).collect();
        sweeps(self.n, &self.factors, &mut y);
        b.copy_from_slice(&y);
    }
}

crate::widest_vectors! {
    /// The forward sweep with the unit lower factor, then the backward one with the upper.
    fn sweeps(n: usize, factors: &[f32], y: &mut [f32]) {
        for j in 0..n {
            let (done, below) = y.split_at_mut(j + 1);
            let y_j = done[j];
            if y_j != 0.0 {
                for (slot, L_ij) in below.iter_mut().zip(&factors[j * n + j + 1..(j + 1) * n]) {
                    *slot -= L_ij * y_j;
                }
            }
        }
        for j in (0..n).rev() {
            let column = &factors[j * n..j * n + j + 1];
            let (above, rest) = y.split_at_mut(j);
            let x_j = rest[0] / column[j];
            rest[0] = x_j;
            if x_j != 0.0 {
                for (slot, U_ij) in above.iter_mut().zip(&column[..j]) {
                    *slot -= U_ij * x_j;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;
    use faer::linalg::solvers::Solve;

    /// A non-symmetric matrix that needs pivoting (small diagonal): the packed solve agrees
    /// with faer's to single-precision rounding, and its residual is at that level.
    #[test]
    fn packed_solve_agrees_with_faer_and_leaves_a_rounding_residual() {
        let n = 97;
        let A = Mat::<f32>::from_fn(n, n, |i, j| {
            let value = ((i * n + j) as f32 * 0.618).sin();
            if i == j { 1e-3 * value } else { value }
        });
        let b: Vec<f32> = (0..n).map(|i| ((i * 13) % 7) as f32 - 3.0).collect();
        let lu = PackedLu::new(A.as_ref());
        let mut x = b.clone();
        lu.solve_in_place(&mut x);
        let by_faer = PartialPivLu::new(A.as_ref()).solve(Mat::from_fn(n, 1, |i, _| b[i]));
        let scale = x.iter().fold(0.0_f32, |m, v| m.max(v.abs()));
        for i in 0..n {
            assert!(
                (x[i] - by_faer[(i, 0)]).abs() <= 1e-3 * scale,
                "unknown {i}: {} against faer's {}",
                x[i],
                by_faer[(i, 0)]
            );
        }
        let (mut worst, mut size) = (0.0_f64, 0.0_f64);
        for i in 0..n {
            let row: f64 = (0..n).map(|j| A[(i, j)] as f64 * x[j] as f64).sum();
            worst = worst.max((row - b[i] as f64).abs());
            size = size.max((0..n).map(|j| (A[(i, j)] as f64 * x[j] as f64).abs()).sum());
        }
        assert!(worst <= 1e-5 * size, "residual {worst:e} against {size:e}");
    }
}

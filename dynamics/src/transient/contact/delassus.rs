//! The Delassus operator `W`: the end-of-step relative velocities of the pairs are affine in
//! their reactions, `w = w_free + W r`.

use faer::{Mat, MatRef};
use squeal_linalg::kernels::{axpy, axpy_single};

/// The Delassus operator, 3 rows and columns per pair in the order (n, t, b), fixed through a
/// run: in double precision, and copied to single precision for the iterations' passes over
/// it (half the bytes, see [`Precision`]); with the projections' step lengths from its
/// diagonal.
pub struct Delassus {
    pub(super) double: Mat<f64>,
    single: Mat<f32>,
    pub(super) step: Step,
}

impl Delassus {
    pub fn new(W: Mat<f64>) -> Delassus {
        let step = Step {
            rho_n: (0..W.nrows() / 3)
                .map(|p| 1.0 / W[(3 * p, 3 * p)])
                .collect(),
            rho_T: (0..W.nrows() / 3)
                .map(|p| 1.0 / W[(3 * p + 1, 3 * p + 1)].max(W[(3 * p + 2, 3 * p + 2)]))
                .collect(),
        };
        Delassus {
            single: Mat::from_fn(W.nrows(), W.ncols(), |i, j| W[(i, j)] as f32),
            double: W,
            step,
        }
    }

    /// `w += W e_k change`, from the copy in `precision`.
    pub(super) fn add_column(&self, k: usize, change: f64, w: &mut [f64], precision: Precision) {
        match precision {
            Precision::Double => axpy(change, column(self.double.as_ref(), k), w),
            Precision::Single => {
                let column = self
                    .single
                    .col(k)
                    .try_as_col_major()
                    .expect("the Delassus operator is stored column-major")
                    .as_slice();
                axpy_single(change, column, w)
            }
        }
    }
}

/// Which copy of `W` an iteration's passes read. A pass in single precision leaves an error
/// of about `2⁻²⁴ |W Δr|` in `w`, `Δr` the pass's change of the reactions: far below a
/// step's change of velocity, but not always below the tolerance. A step solved so is
/// accepted on its end-of-step velocities, computed in double precision from the solution
/// ([`ContactSolver::settle`](super::ContactSolver::settle)), or refined in double precision.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Precision {
    Single,
    Double,
}

/// The projections' step lengths `ρ` per pair, from the diagonal of `W`.
pub(super) struct Step {
    pub(super) rho_n: Vec<f64>,
    pub(super) rho_T: Vec<f64>,
}

/// Column `k` of `W` as a slice (`W` is stored column-major).
pub(super) fn column<'a>(W: MatRef<'a, f64>, k: usize) -> &'a [f64] {
    W.col(k)
        .try_as_col_major()
        .expect("the Delassus operator is stored column-major")
        .as_slice()
}

squeal_linalg::widest_vectors! {
    /// `w = w_free + W r`, column by column (contiguous reads).
    pub(super) fn velocities(W: &Delassus, w_free: &[f64], r: &[f64], w: &mut [f64]) {
        w.copy_from_slice(w_free);
        for (k, &r_k) in r.iter().enumerate() {
            if r_k != 0.0 {
                for (slot, W_ik) in w.iter_mut().zip(column(W.double.as_ref(), k)) {
                    *slot += W_ik * r_k;
                }
            }
        }
    }
}

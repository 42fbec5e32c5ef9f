//! The products a step needs, `(M v, C v, K v)` per DOF, for one pass over memory.
//!
//! A step's `M v¹` never needs a product: the step's own equation gives it,
//!
//! ```text
//! J v¹ = M v¹/τ + θ C v¹ + τθ² K v¹   ⇒   M v¹ = τ (J v¹ − θ C v¹ − τθ² K v¹)
//! ```
//!
//! with `J v¹` the right-hand side just solved. In general `C v¹` and `K v¹` then come from one
//! pass over the union of their patterns ([`Products::Fused`]). When the damping is Rayleigh's
//! row by row, `C = diag(a) M + diag(b) K` (Rayleigh damping per part, on parts that share no
//! node: the FE models' case), `C v¹` needs no product either: row by row,
//!
//! ```text
//! (J v)_i = (1/τ + θ a_i)(M v)_i + (θ b_i + τθ²)(K v)_i
//! ⇒  (M v)_i = τ ((J v)_i − (θ b_i + τθ²)(K v)_i) / (1 + τθ a_i),
//!    (C v)_i = a_i (M v)_i + b_i (K v)_i
//! ```
//!
//! so a step streams `K` alone ([`Products::Rayleigh`]), 12 bytes an entry instead of 20. The
//! rows' `a`, `b` are found by least squares on each row's entries and accepted only if every
//! entry of `C` (and every zero of `C` under an entry of `M` or `K`) agrees to rounding
//! (`RAYLEIGH_TOLERANCE` of the row's largest terms); otherwise the fused products are used.
//! Either way the products are summed row by row in a fixed order, so their bits do not depend
//! on the thread count.

use rayon::prelude::*;
use squeal_linalg::CscMatrix;

/// Rows of each fixed chunk of the products (independent of the thread count).
const PRODUCT_CHUNK: usize = 4096;
/// How closely `C` must be `diag(a) M + diag(b) K`, relative to the row's largest terms.
const RAYLEIGH_TOLERANCE: f64 = 1e-12;

/// One symmetric matrix or two, read row by row (as columns: they are symmetric).
pub(crate) struct Rows<const N: usize> {
    col_ptr: Vec<usize>,
    /// `u32` halves the index traffic: the product is bound by memory bandwidth.
    row_idx: Vec<u32>,
    values: Vec<[f64; N]>,
}

impl<const N: usize> Rows<N> {
    /// The union of the matrices' patterns, with each matrix's values.
    fn new(matrices: [&CscMatrix; N]) -> Rows<N> {
        let n = matrices[0].n_cols;
        assert!(n <= u32::MAX as usize, "more unknowns than u32 indices");
        let mut col_ptr = vec![0];
        let mut row_idx = Vec::new();
        let mut values: Vec<[f64; N]> = Vec::new();
        let mut column: Vec<(usize, usize, f64)> = Vec::new();
        for col in 0..n {
            column.clear();
            for (which, A) in matrices.iter().enumerate() {
                for entry in A.col_ptr[col]..A.col_ptr[col + 1] {
                    column.push((A.row_idx[entry], which, A.values[entry]));
                }
            }
            column.sort_by_key(|&(row, which, _)| (row, which));
            let mut last = usize::MAX;
            for &(row, which, value) in &column {
                if row != last {
                    row_idx.push(row as u32);
                    values.push([0.0; N]);
                    last = row;
                }
                values.last_mut().expect("an entry was pushed")[which] += value;
            }
            col_ptr.push(row_idx.len());
        }
        Rows {
            col_ptr,
            row_idx,
            values,
        }
    }

    /// Row `i` times `x`, for each matrix.
    fn row_times(&self, i: usize, x: &[f64]) -> [f64; N] {
        let mut sum = [0.0; N];
        for entry in self.col_ptr[i]..self.col_ptr[i + 1] {
            let value = self.values[entry];
            let x_j = x[self.row_idx[entry] as usize];
            for (slot, value) in sum.iter_mut().zip(value) {
                *slot += value * x_j;
            }
        }
        sum
    }
}

/// How a run gets its products.
pub(crate) enum Products {
    /// `C` and `K` in one pass over their union pattern.
    Fused(Rows<2>),
    /// `K` alone: `C = diag(a) M + diag(b) K`.
    Rayleigh {
        K: Rows<1>,
        a: Vec<f64>,
        b: Vec<f64>,
    },
}

impl Products {
    pub fn new(M: &CscMatrix, C: &CscMatrix, K: &CscMatrix) -> Products {
        match rayleigh_rows(M, C, K) {
            Some((a, b)) => Products::Rayleigh {
                K: Rows::new([K]),
                a,
                b,
            },
            None => Products::Fused(Rows::new([C, K])),
        }
    }

    /// Whether a step streams `K` alone.
    #[cfg(test)]
    pub fn is_rayleigh(&self) -> bool {
        matches!(self, Products::Rayleigh { .. })
    }

    /// `C x` and `K x` into the last two slots of `out`, given `M x` in its first.
    pub fn with_mass(&self, x: &[f64], out: &mut [[f64; 3]]) {
        self.by_chunks(out, |i, slot| match self {
            Products::Fused(CK) => [slot[1], slot[2]] = CK.row_times(i, x),
            Products::Rayleigh { K, a, b } => {
                let [K_x] = K.row_times(i, x);
                slot[1] = a[i] * slot[0] + b[i] * K_x;
                slot[2] = K_x;
            }
        });
    }

    /// `(M x, C x, K x)` into `out` for a step's solution `x`, given `J x` (the right-hand side
    /// it solved), `J = M/τ + θ C + τθ² K`.
    pub fn of_solution(&self, x: &[f64], J_x: &[f64], tau: f64, theta: f64, out: &mut [[f64; 3]]) {
        self.by_chunks(out, |i, slot| match self {
            Products::Fused(CK) => {
                let [C_x, K_x] = CK.row_times(i, x);
                *slot = [
                    tau * (J_x[i] - theta * C_x - tau * theta * theta * K_x),
                    C_x,
                    K_x,
                ];
            }
            Products::Rayleigh { K, a, b } => {
                let [K_x] = K.row_times(i, x);
                let M_x = tau * (J_x[i] - (theta * b[i] + tau * theta * theta) * K_x)
                    / (1.0 + tau * theta * a[i]);
                *slot = [M_x, a[i] * M_x + b[i] * K_x, K_x];
            }
        });
    }

    fn by_chunks(&self, out: &mut [[f64; 3]], row: impl Fn(usize, &mut [f64; 3]) + Sync) {
        out.par_chunks_mut(PRODUCT_CHUNK)
            .enumerate()
            .for_each(|(chunk, slots)| {
                for (offset, slot) in slots.iter_mut().enumerate() {
                    row(chunk * PRODUCT_CHUNK + offset, slot);
                }
            });
    }
}

/// `(a, b)` with `C = diag(a) M + diag(b) K` to rounding, if there are such.
fn rayleigh_rows(M: &CscMatrix, C: &CscMatrix, K: &CscMatrix) -> Option<(Vec<f64>, Vec<f64>)> {
    let MCK = Rows::new([M, C, K]);
    let n = M.n_cols;
    let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
    for i in 0..n {
        let entries = &MCK.values[MCK.col_ptr[i]..MCK.col_ptr[i + 1]];
        let (mut mm, mut mk, mut kk, mut mc, mut kc) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for &[m, c, k] in entries {
            mm += m * m;
            mk += m * k;
            kk += k * k;
            mc += m * c;
            kc += k * c;
        }
        let det = mm * kk - mk * mk;
        (a[i], b[i]) = if det > 1e-12 * mm * kk {
            ((mc * kk - kc * mk) / det, (kc * mm - mc * mk) / det)
        } else if mm > 0.0 {
            // M's row and K's are proportional (or K's is zero): any split fits, take C = a M.
            (mc / mm, 0.0)
        } else if kk > 0.0 {
            (0.0, kc / kk)
        } else {
            (0.0, 0.0)
        };
        // Assembly rounds each entry to the size of the row's largest terms.
        let size = |&[m, c, k]: &[f64; 3]| c.abs() + (a[i] * m).abs() + (b[i] * k).abs();
        let scale = entries.iter().map(size).fold(0.0, f64::max);
        let fits = entries
            .iter()
            .all(|&[m, c, k]| (c - a[i] * m - b[i] * k).abs() <= RAYLEIGH_TOLERANCE * scale);
        if !fits {
            return None;
        }
    }
    Some((a, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A symmetric tridiagonal matrix with diagonal `d` and off-diagonal `e`.
    fn tridiagonal(n: usize, d: impl Fn(usize) -> f64, e: impl Fn(usize) -> f64) -> CscMatrix {
        let mut triplets = Vec::new();
        for i in 0..n {
            triplets.push((i, i, d(i)));
            if i + 1 < n {
                triplets.push((i, i + 1, e(i)));
                triplets.push((i + 1, i, e(i)));
            }
        }
        CscMatrix::from_triplets(n, n, triplets)
    }

    fn combination(terms: &[(f64, &CscMatrix)]) -> CscMatrix {
        let n = terms[0].1.n_cols;
        let triplets = terms
            .iter()
            .flat_map(|&(factor, A)| A.triplets().map(move |(i, j, v)| (i, j, factor * v)))
            .collect();
        CscMatrix::from_triplets(n, n, triplets)
    }

    /// Two parts sharing no DOF, each with its own Rayleigh damping: C is found to be
    /// `diag(a) M + diag(b) K`, and both kinds of products agree to rounding, with `M x`
    /// derived from `J x`.
    #[test]
    fn rayleigh_damping_per_part_streams_k_alone_and_agrees_with_the_fused_products() {
        let n = 40;
        let M = tridiagonal(
            n,
            |i| 2.0 + 0.01 * i as f64,
            |i| if i == 19 { 0.0 } else { 0.5 },
        );
        let K = tridiagonal(
            n,
            |i| 3e8 + 1e6 * i as f64,
            |i| if i == 19 { 0.0 } else { -1e8 },
        );
        let part = |i: usize| usize::from(i >= 20);
        let (alpha, beta) = ([3.0, 40.0], [2e-6, 5e-8]);
        let triplets = [(&M, alpha), (&K, beta)]
            .into_iter()
            .flat_map(|(A, coefficients)| {
                A.triplets()
                    .map(move |(row, col, value)| (row, col, coefficients[part(row)] * value))
            })
            .collect();
        let C = CscMatrix::from_triplets(n, n, triplets);
        let rayleigh = Products::new(&M, &C, &K);
        assert!(rayleigh.is_rayleigh());
        let fused = Products::Fused(Rows::new([&C, &K]));
        let (tau, theta) = (1e-6, 0.6);
        let J = combination(&[(1.0 / tau, &M), (theta, &C), (tau * theta * theta, &K)]);
        let x: Vec<f64> = (0..n).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
        let J_x = J.mul_vec(&x);
        let (mut by_rayleigh, mut by_fused) = (vec![[0.0; 3]; n], vec![[0.0; 3]; n]);
        rayleigh.of_solution(&x, &J_x, tau, theta, &mut by_rayleigh);
        fused.of_solution(&x, &J_x, tau, theta, &mut by_fused);
        let exact = [M.mul_vec(&x), C.mul_vec(&x), K.mul_vec(&x)];
        for i in 0..n {
            for d in 0..3 {
                let scale = exact[d].iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                for got in [by_rayleigh[i][d], by_fused[i][d]] {
                    assert!(
                        (got - exact[d][i]).abs() <= 1e-8 * scale,
                        "row {i}, product {d}: {got} against {}",
                        exact[d][i]
                    );
                }
            }
        }
        // Given M x, both give C x and K x.
        let mut given: Vec<[f64; 3]> = exact[0].iter().map(|&m| [m, 0.0, 0.0]).collect();
        rayleigh.with_mass(&x, &mut given);
        for i in 0..n {
            let scale = exact[1].iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            assert!((given[i][1] - exact[1][i]).abs() <= 1e-12 * scale);
            assert_eq!(given[i][2], exact[2][i]);
        }
    }

    /// Damping that is not row-wise Rayleigh (a dashpot between two DOFs of different
    /// rows' coefficients) keeps the fused products.
    #[test]
    fn other_damping_keeps_the_fused_products() {
        let n = 6;
        let M = tridiagonal(n, |_| 1.0, |_| 0.0);
        let K = tridiagonal(n, |_| 2.0, |_| -1.0);
        let C = tridiagonal(
            n,
            |i| if i == 2 { 0.7 } else { 0.1 },
            |i| if i == 2 { -0.4 } else { 0.0 },
        );
        assert!(!Products::new(&M, &C, &K).is_rayleigh());
    }
}

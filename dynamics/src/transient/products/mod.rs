//! The products a step needs, `(M v, C v, K v)` per DOF, for one pass over memory.
//!
//! A step's `M v¹` never needs a product: the step's own equation gives it,
//!
//! ```text
//! J v¹ = M v¹/τ + θ C v¹ + τθ² K v¹   ⇒   M v¹ = τ (J v¹ − θ C v¹ − τθ² K v¹)
//! ```
//!
//! with `J v¹` the right-hand side just solved. In general `C v¹` and `K v¹` then come from one
//! pass over their lower triangles, stored as runs of consecutive rows ([`Products::Fused`],
//! [`LowerRuns`]: a reduced model's dense matrices). When the damping is Rayleigh's row by
//! row, `C = diag(a) M + diag(b) K` (Rayleigh damping per part, on parts that share no node:
//! the FE models' case), `C v¹` needs no product either: row by row,
//!
//! ```text
//! (J v)_i = (1/τ + θ a_i)(M v)_i + (θ b_i + τθ²)(K v)_i
//! ⇒  (M v)_i = τ ((J v)_i − (θ b_i + τθ²)(K v)_i) / (1 + τθ a_i),
//!    (C v)_i = a_i (M v)_i + b_i (K v)_i
//! ```
//!
//! so a step streams `K` alone ([`Products::Rayleigh`]; [`Stiffness`]: both triangles row by
//! row, 12 bytes an entry, for an FE model's sparse `K`, its lower triangle's runs, 8 bytes an
//! entry of one triangle, for a reduced model's dense blocks). The rows' `a`, `b` are found by
//! least squares on each row's entries and accepted only if every entry of `C` (and every zero
//! of `C` under an entry of `M` or `K`) agrees to rounding (`RAYLEIGH_TOLERANCE` of the row's
//! largest terms); otherwise the fused products are used. Either way every sum's order is fixed by the pattern, so the bits do not depend on
//! the thread count.

use rayon::prelude::*;
use squeal_linalg::CscMatrix;
use squeal_linalg::kernels::dot_and_axpy;

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
        let mut column = Vec::new();
        for col in 0..n {
            union_column(matrices, col, &mut column);
            for &(row, value) in &column {
                row_idx.push(row as u32);
                values.push(value);
            }
            col_ptr.push(row_idx.len());
        }
        Rows {
            col_ptr,
            row_idx,
            values,
        }
    }

    /// Every row times `x`, for each matrix, over fixed chunks of rows in parallel.
    fn times(&self, x: &[f64]) -> Vec<[f64; N]> {
        let mut out = vec![[0.0; N]; x.len()];
        by_chunks(&mut out, |i, slot| *slot = self.row_times(i, x));
        out
    }

    /// Bytes a product reads of the matrices.
    fn bytes(&self) -> usize {
        self.col_ptr.len() * 8 + self.row_idx.len() * (4 + 8 * N)
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

/// Column `col` of the union of the matrices' patterns into `column`: `(row, each matrix's
/// value)`, ascending (a merge of the matrices' columns, whose rows ascend).
fn union_column<const N: usize>(
    matrices: [&CscMatrix; N],
    col: usize,
    column: &mut Vec<(usize, [f64; N])>,
) {
    let mut next = matrices.map(|A| A.col_ptr[col]);
    let end = matrices.map(|A| A.col_ptr[col + 1]);
    column.clear();
    loop {
        let row = (0..N)
            .filter(|&k| next[k] < end[k])
            .map(|k| matrices[k].row_idx[next[k]])
            .min();
        let Some(row) = row else { break };
        let mut values = [0.0; N];
        for k in 0..N {
            if next[k] < end[k] && matrices[k].row_idx[next[k]] == row {
                values[k] = matrices[k].values[next[k]];
                next[k] += 1;
            }
        }
        column.push((row, values));
    }
}

/// Columns of each fixed chunk of [`LowerRuns`]'s product (independent of the thread count).
const RUN_CHUNK: usize = 256;

/// Symmetric matrices by their lower triangles, each column's entries below the diagonal
/// stored as runs of consecutive rows: `C` and `K` for the fused products, or `K` alone. A
/// reduced model's matrices are dense but
/// for the blocks between separate bodies (and `K`'s between the interface and the vectors,
/// [`super::reduced`]), so a column is a few long runs: the product reads each stored entry
/// once and no index per entry, for its row (a dot product with `x`) and for its column (`x_j`
/// times the run, added to the rows below). A symmetric pair of entries costs 8 bytes of each
/// matrix that holds it, where both triangles with an index per entry cost 40 for the two.
///
/// The columns are split into fixed chunks ([`RUN_CHUNK`]), each adding into its own partial
/// sums of the rows from its first column on; row `i` adds its chunks' partials in chunk
/// order. Every sum's order is fixed by the pattern alone, so the bits do not depend on the
/// thread count.
pub(crate) struct LowerRuns<const N: usize> {
    triangles: [Triangle; N],
}

/// One symmetric matrix's lower triangle as runs.
struct Triangle {
    diagonal: Vec<f64>,
    /// Column `j`'s runs are `runs[col_runs[j]..col_runs[j + 1]]`.
    col_runs: Vec<usize>,
    runs: Vec<Run>,
    /// The runs' values, one after the other in run order.
    values: Vec<f64>,
}

/// Rows `first..first + len` of a column, their values at `offset..offset + len`.
struct Run {
    first: usize,
    offset: usize,
    len: usize,
}

impl Triangle {
    /// The lower triangle of the matrix `rows` holds.
    fn new(rows: &Rows<1>) -> Triangle {
        let n = rows.col_ptr.len() - 1;
        let mut triangle = Triangle {
            diagonal: vec![0.0; n],
            col_runs: vec![0],
            runs: Vec::new(),
            values: Vec::new(),
        };
        for j in 0..n {
            for entry in rows.col_ptr[j]..rows.col_ptr[j + 1] {
                let (row, [value]) = (rows.row_idx[entry] as usize, rows.values[entry]);
                if row == j {
                    triangle.diagonal[j] = value;
                } else if row > j {
                    // A run continues within its column only.
                    let in_column = triangle.col_runs[j] < triangle.runs.len();
                    match triangle.runs.last_mut() {
                        Some(run) if in_column && run.first + run.len == row => run.len += 1,
                        _ => triangle.runs.push(Run {
                            first: row,
                            offset: triangle.values.len(),
                            len: 1,
                        }),
                    }
                    triangle.values.push(value);
                }
            }
            triangle.col_runs.push(triangle.runs.len());
        }
        triangle
    }

    /// Column `j` of the lower triangle times `x_j` added to `partial` (rows from `start` on),
    /// and its dot product with `x`, with the diagonal's, added to row `j`.
    fn column_times(&self, j: usize, x: &[f64], start: usize, partial: &mut [f64]) {
        let mut gathered = self.diagonal[j] * x[j];
        for run in &self.runs[self.col_runs[j]..self.col_runs[j + 1]] {
            let rows = run.first - start..run.first - start + run.len;
            gathered += dot_and_axpy(
                &self.values[run.offset..run.offset + run.len],
                &x[run.first..run.first + run.len],
                x[j],
                &mut partial[rows],
            );
        }
        partial[j - start] += gathered;
    }
}

impl<const N: usize> LowerRuns<N> {
    fn new(matrices: [&CscMatrix; N]) -> LowerRuns<N> {
        LowerRuns {
            triangles: matrices.map(|A| Triangle::new(&Rows::new([A]))),
        }
    }

    /// Every row times `x`, for each matrix.
    fn times(&self, x: &[f64]) -> Vec<[f64; N]> {
        let n = x.len();
        let partials: Vec<[Vec<f64>; N]> = (0..n.div_ceil(RUN_CHUNK))
            .into_par_iter()
            .map(|chunk| {
                let start = chunk * RUN_CHUNK;
                let mut partial: [Vec<f64>; N] = std::array::from_fn(|_| vec![0.0; n - start]);
                for j in start..(start + RUN_CHUNK).min(n) {
                    for (triangle, partial) in self.triangles.iter().zip(&mut partial) {
                        triangle.column_times(j, x, start, partial);
                    }
                }
                partial
            })
            .collect();
        (0..n)
            .map(|i| {
                let mut sum = [0.0; N];
                for (chunk, parts) in partials[..=i / RUN_CHUNK].iter().enumerate() {
                    for (slot, part) in sum.iter_mut().zip(parts) {
                        *slot += part[i - chunk * RUN_CHUNK];
                    }
                }
                sum
            })
            .collect()
    }

    /// Bytes a product reads and writes: the triangles, and each chunk's partial sums.
    fn bytes(&self) -> usize {
        let n = self.triangles[0].diagonal.len();
        let partials: usize = (0..n).step_by(RUN_CHUNK).map(|start| n - start).sum();
        self.triangles
            .iter()
            .map(|triangle| {
                8 * (triangle.diagonal.len() + triangle.col_runs.len() + triangle.values.len())
                    + std::mem::size_of::<Run>() * triangle.runs.len()
                    + 16 * partials
            })
            .sum()
    }
}

/// `K` in whichever layout a product reads fewer bytes of: both triangles with an index per
/// entry (an FE model's sparse `K`, whose runs are a node's few DOFs), or the lower
/// triangle's runs (a reduced model's dense blocks, a third of the bytes).
pub(crate) enum Stiffness {
    Rows(Rows<1>),
    Runs(LowerRuns<1>),
}

impl Stiffness {
    fn new(K: &CscMatrix) -> Stiffness {
        let rows = Rows::new([K]);
        let runs = LowerRuns {
            triangles: [Triangle::new(&rows)],
        };
        if runs.bytes() < rows.bytes() {
            Stiffness::Runs(runs)
        } else {
            Stiffness::Rows(rows)
        }
    }

    fn times(&self, x: &[f64]) -> Vec<[f64; 1]> {
        match self {
            Stiffness::Rows(rows) => rows.times(x),
            Stiffness::Runs(runs) => runs.times(x),
        }
    }
}

/// How a run gets its products.
pub(crate) enum Products {
    /// `C` and `K` in one pass over their lower triangles.
    Fused(LowerRuns<2>),
    /// `K` alone: `C = diag(a) M + diag(b) K`.
    Rayleigh {
        K: Stiffness,
        a: Vec<f64>,
        b: Vec<f64>,
    },
}

impl Products {
    pub fn new(M: &CscMatrix, C: &CscMatrix, K: &CscMatrix) -> Products {
        match rayleigh_rows(M, C, K) {
            Some((a, b)) => Products::Rayleigh {
                K: Stiffness::new(K),
                a,
                b,
            },
            None => Products::fused(C, K),
        }
    }

    fn fused(C: &CscMatrix, K: &CscMatrix) -> Products {
        Products::Fused(LowerRuns::new([C, K]))
    }

    /// Whether a step streams `K` alone.
    #[cfg(test)]
    pub fn is_rayleigh(&self) -> bool {
        matches!(self, Products::Rayleigh { .. })
    }

    /// Whether a step streams `K` alone, by its lower triangle's runs.
    #[cfg(test)]
    pub fn streams_lower_runs(&self) -> bool {
        matches!(
            self,
            Products::Rayleigh {
                K: Stiffness::Runs(_),
                ..
            }
        )
    }

    /// `C x` and `K x` into the last two slots of `out`, given `M x` in its first.
    pub fn with_mass(&self, x: &[f64], out: &mut [[f64; 3]]) {
        match self {
            Products::Fused(CK) => {
                for (slot, [C_x, K_x]) in out.iter_mut().zip(CK.times(x)) {
                    [slot[1], slot[2]] = [C_x, K_x];
                }
            }
            Products::Rayleigh { K, a, b } => {
                for (i, (slot, [K_x])) in out.iter_mut().zip(K.times(x)).enumerate() {
                    slot[1] = a[i] * slot[0] + b[i] * K_x;
                    slot[2] = K_x;
                }
            }
        }
    }

    /// `(M x, C x, K x)` into `out` for a step's solution `x`, given `J x` (the right-hand side
    /// it solved), `J = M/τ + θ C + τθ² K`.
    pub fn of_solution(&self, x: &[f64], J_x: &[f64], tau: f64, theta: f64, out: &mut [[f64; 3]]) {
        match self {
            Products::Fused(CK) => {
                for (i, (slot, [C_x, K_x])) in out.iter_mut().zip(CK.times(x)).enumerate() {
                    *slot = [
                        tau * (J_x[i] - theta * C_x - tau * theta * theta * K_x),
                        C_x,
                        K_x,
                    ];
                }
            }
            Products::Rayleigh { K, a, b } => {
                for (i, (slot, [K_x])) in out.iter_mut().zip(K.times(x)).enumerate() {
                    let M_x = tau * (J_x[i] - (theta * b[i] + tau * theta * theta) * K_x)
                        / (1.0 + tau * theta * a[i]);
                    *slot = [M_x, a[i] * M_x + b[i] * K_x, K_x];
                }
            }
        }
    }
}

/// `row(i, out_i)` for every row, over fixed chunks of rows in parallel.
fn by_chunks<T: Send>(out: &mut [T], row: impl Fn(usize, &mut T) + Sync) {
    out.par_chunks_mut(PRODUCT_CHUNK)
        .enumerate()
        .for_each(|(chunk, slots)| {
            for (offset, slot) in slots.iter_mut().enumerate() {
                row(chunk * PRODUCT_CHUNK + offset, slot);
            }
        });
}

/// `(a, b)` with `C = diag(a) M + diag(b) K` to rounding, if there are such.
fn rayleigh_rows(M: &CscMatrix, C: &CscMatrix, K: &CscMatrix) -> Option<(Vec<f64>, Vec<f64>)> {
    let n = M.n_cols;
    let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
    let mut column = Vec::new();
    // Last row first: a reduced model's modal coordinates come last and are not Rayleigh's
    // (its interface rows are), so its check ends on its first row.
    for i in (0..n).rev() {
        union_column([M, C, K], i, &mut column);
        let entries = column.iter().map(|(_, values)| values);
        let (mut mm, mut mk, mut kk, mut mc, mut kc) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for &[m, c, k] in entries.clone() {
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
        let scale = entries.clone().map(size).fold(0.0, f64::max);
        let fits = entries
            .clone()
            .all(|&[m, c, k]| (c - a[i] * m - b[i] * k).abs() <= RAYLEIGH_TOLERANCE * scale);
        if !fits {
            return None;
        }
    }
    Some((a, b))
}

#[cfg(test)]
mod tests;

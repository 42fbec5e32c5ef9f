//! Sparse products of the symmetric model matrices with blocks of vectors, and checks of the
//! properties the eigensolver relies on.

use faer::{Mat, MatRef};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::Error;

/// Rows per parallel task in a product: large enough to amortise scheduling.
const ROWS_PER_TASK: usize = 2048;

/// `Y = A X` for a symmetric `A` stored with both triangles. Row `j` of `A X` is column `j` of
/// `A` dotted with `X` (symmetry), so each output entry is one sequential sum: parallel and
/// deterministic. `X` is first copied row-major so that one pass over `A` serves every column.
pub fn symmetric_mul(A: &CscMatrix, X: MatRef<'_, f64>) -> Mat<f64> {
    let (n, p) = (A.n_rows, X.ncols());
    if p == 1 {
        // One vector: the same sums, without the row-major copies.
        let x: Vec<f64> = X.col(0).iter().copied().collect();
        let mut y = vec![0.0; n];
        y.par_chunks_mut(ROWS_PER_TASK)
            .enumerate()
            .for_each(|(chunk, y_chunk)| {
                for (offset, y_j) in y_chunk.iter_mut().enumerate() {
                    *y_j = column_dot(A, chunk * ROWS_PER_TASK + offset, |row| x[row]);
                }
            });
        return Mat::from_fn(n, 1, |i, _| y[i]);
    }
    let mut X_rows = vec![0.0; n * p];
    for k in 0..p {
        for (i, value) in X.col(k).iter().enumerate() {
            X_rows[i * p + k] = *value;
        }
    }
    let mut Y_rows = vec![0.0; n * p];
    Y_rows
        .par_chunks_mut(ROWS_PER_TASK * p.max(1))
        .enumerate()
        .for_each(|(chunk, Y_chunk)| {
            let first_row = chunk * ROWS_PER_TASK;
            for (offset, y) in Y_chunk.chunks_exact_mut(p.max(1)).enumerate() {
                let j = first_row + offset;
                for entry in A.col_ptr[j]..A.col_ptr[j + 1] {
                    let value = A.values[entry];
                    let x = &X_rows[A.row_idx[entry] * p..][..p];
                    for (y_k, x_k) in y.iter_mut().zip(x) {
                        *y_k += value * x_k;
                    }
                }
            }
        });
    Mat::from_fn(n, p, |i, k| Y_rows[i * p + k])
}

/// Rows `rows` of `A X` for a symmetric `A`: each entry the sum [`symmetric_mul`] forms.
pub fn symmetric_mul_rows(A: &CscMatrix, rows: &[usize], X: MatRef<'_, f64>) -> Mat<f64> {
    Mat::from_fn(rows.len(), X.ncols(), |r, k| {
        column_dot(A, rows[r], |row| X[(row, k)])
    })
}

/// Column `j` of `A`, in stored order, dotted with `x` (given entry by entry): row `j` of
/// `A x` for a symmetric `A`.
fn column_dot(A: &CscMatrix, j: usize, x: impl Fn(usize) -> f64) -> f64 {
    let entries = A.col_ptr[j]..A.col_ptr[j + 1];
    A.row_idx[entries.clone()]
        .iter()
        .zip(&A.values[entries])
        .fold(0.0, |sum, (&row, &value)| sum + value * x(row))
}

/// The diagonal of `A`.
pub fn diagonal(A: &CscMatrix) -> Vec<f64> {
    (0..A.n_cols)
        .map(|j| {
            let rows = &A.row_idx[A.col_ptr[j]..A.col_ptr[j + 1]];
            rows.binary_search(&j)
                .map_or(0.0, |position| A.values[A.col_ptr[j] + position])
        })
        .collect()
}

/// Checks that `A` is a well-formed square CSC matrix of size `n` with sorted rows, finite
/// values and symmetric to roundoff; `name` is used in the message.
pub fn check_symmetric(A: &CscMatrix, n: usize, name: &str) -> Result<(), Error> {
    if A.n_rows != n || A.n_cols != n || A.col_ptr.len() != n + 1 {
        return Err(Error::InvalidInput(format!(
            "{name} is {}×{} but the model has {n} DOFs",
            A.n_rows, A.n_cols
        )));
    }
    let nnz = A.col_ptr[n];
    if A.row_idx.len() != nnz || A.values.len() != nnz || A.col_ptr[0] != 0 {
        return Err(Error::InvalidInput(format!(
            "{name} is malformed: {} column pointers end at {nnz} but it stores {} row indices and {} values",
            n + 1,
            A.row_idx.len(),
            A.values.len()
        )));
    }
    let scale = A
        .values
        .iter()
        .fold(0.0f64, |max, value| max.max(value.abs()));
    let problem = (0..n).into_par_iter().find_map_first(|j| {
        let (start, end) = (A.col_ptr[j], A.col_ptr[j + 1]);
        if end < start {
            return Some(format!("{name} is malformed: column {j} has a negative length"));
        }
        let rows = &A.row_idx[start..end];
        if rows.windows(2).any(|pair| pair[0] >= pair[1]) || rows.iter().any(|&row| row >= n) {
            return Some(format!(
                "{name} is malformed: rows of column {j} are unsorted or out of range"
            ));
        }
        for (offset, &i) in rows.iter().enumerate() {
            let value = A.values[start + offset];
            if !value.is_finite() {
                return Some(format!("{name}[{i}, {j}] = {value} is not finite"));
            }
            let transposed_rows = &A.row_idx[A.col_ptr[i]..A.col_ptr[i + 1]];
            let transposed = transposed_rows
                .binary_search(&j)
                .map_or(0.0, |position| A.values[A.col_ptr[i] + position]);
            if (value - transposed).abs() > 1e-12 * scale {
                return Some(format!(
                    "{name} is not symmetric: {name}[{i}, {j}] = {value:e} but {name}[{j}, {i}] = {transposed:e}"
                ));
            }
        }
        None
    });
    match problem {
        Some(message) => Err(Error::InvalidInput(message)),
        None => Ok(()),
    }
}

/// A sparse matrix in compressed sparse column form, both triangles stored for symmetric
/// matrices. Row indices are sorted within each column.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CscMatrix {
    pub n_rows: usize,
    pub n_cols: usize,
    /// `col_ptr[j]..col_ptr[j + 1]` indexes the entries of column `j`.
    pub col_ptr: Vec<usize>,
    pub row_idx: Vec<usize>,
    pub values: Vec<f64>,
}

impl CscMatrix {
    /// y = A x.
    pub fn mul_vec(&self, x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; self.n_rows];
        for (col, x_col) in x.iter().enumerate().take(self.n_cols) {
            for entry in self.col_ptr[col]..self.col_ptr[col + 1] {
                y[self.row_idx[entry]] += self.values[entry] * x_col;
            }
        }
        y
    }
}

impl CscMatrix {
    /// The `n_rows × n_cols` matrix with the sum of the values of each (row, col) of
    /// `triplets` (duplicates add up, as in assembly); rows sorted within columns.
    pub fn from_triplets(
        n_rows: usize,
        n_cols: usize,
        mut triplets: Vec<(usize, usize, f64)>,
    ) -> CscMatrix {
        triplets.sort_unstable_by_key(|&(row, col, _)| (col, row));
        let mut col_ptr = vec![0usize; n_cols + 1];
        let mut row_idx = Vec::with_capacity(triplets.len());
        let mut values: Vec<f64> = Vec::with_capacity(triplets.len());
        let mut last = None;
        for (row, col, value) in triplets {
            if last == Some((row, col)) {
                *values.last_mut().expect("an entry was pushed") += value;
                continue;
            }
            last = Some((row, col));
            row_idx.push(row);
            values.push(value);
            col_ptr[col + 1] += 1;
        }
        for col in 0..n_cols {
            col_ptr[col + 1] += col_ptr[col];
        }
        CscMatrix {
            n_rows,
            n_cols,
            col_ptr,
            row_idx,
            values,
        }
    }

    /// `Aᵀ`.
    pub fn transpose(&self) -> CscMatrix {
        CscMatrix::from_triplets(
            self.n_cols,
            self.n_rows,
            self.triplets()
                .map(|(row, col, value)| (col, row, value))
                .collect(),
        )
    }

    /// `‖A‖₁`, the largest absolute column sum.
    pub fn norm_1(&self) -> f64 {
        (0..self.n_cols)
            .map(|col| {
                self.values[self.col_ptr[col]..self.col_ptr[col + 1]]
                    .iter()
                    .map(|value| value.abs())
                    .sum::<f64>()
            })
            .fold(0.0, f64::max)
    }

    /// The dense matrix (entries of a repeated (row, col) add up).
    pub fn to_dense(&self) -> Mat<f64> {
        let mut dense = Mat::<f64>::zeros(self.n_rows, self.n_cols);
        for (row, col, value) in self.triplets() {
            dense[(row, col)] += value;
        }
        dense
    }

    /// The entries as (row, col, value).
    pub fn triplets(&self) -> impl Iterator<Item = (usize, usize, f64)> + '_ {
        (0..self.n_cols).flat_map(move |col| {
            (self.col_ptr[col]..self.col_ptr[col + 1])
                .map(move |entry| (self.row_idx[entry], col, self.values[entry]))
        })
    }

    /// `A[indices, indices]` of a square `A`, `indices` ascending: its entries in stored order.
    pub fn principal_submatrix(&self, indices: &[usize]) -> CscMatrix {
        let mut position = vec![usize::MAX; self.n_rows];
        for (k, &index) in indices.iter().enumerate() {
            position[index] = k;
        }
        let mut col_ptr = Vec::with_capacity(indices.len() + 1);
        col_ptr.push(0);
        let (mut row_idx, mut values) = (Vec::new(), Vec::new());
        for &col in indices {
            for entry in self.col_ptr[col]..self.col_ptr[col + 1] {
                let row = position[self.row_idx[entry]];
                if row != usize::MAX {
                    row_idx.push(row);
                    values.push(self.values[entry]);
                }
            }
            col_ptr.push(row_idx.len());
        }
        CscMatrix {
            n_rows: indices.len(),
            n_cols: indices.len(),
            col_ptr,
            row_idx,
            values,
        }
    }
}

/// The diagonal blocks into which a symmetric permutation puts square matrices of one size
/// together: the connected components of their patterns' union, each one's indices ascending,
/// the components by their smallest index. No matrix couples two components.
pub fn components(matrices: &[&CscMatrix]) -> Vec<Vec<usize>> {
    let n = matrices.first().map_or(0, |A| A.n_cols);
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut index: usize) -> usize {
        while parent[index] != index {
            parent[index] = parent[parent[index]];
            index = parent[index];
        }
        index
    }
    for A in matrices {
        for (row, col, _) in A.triplets() {
            let (a, b) = (root(&mut parent, row), root(&mut parent, col));
            // The smaller index is the root, so a component's root is its smallest index.
            parent[a.max(b)] = a.min(b);
        }
    }
    let mut component_of_root = vec![usize::MAX; n];
    let mut components: Vec<Vec<usize>> = Vec::new();
    for index in 0..n {
        let top = root(&mut parent, index);
        if component_of_root[top] == usize::MAX {
            component_of_root[top] = components.len();
            components.push(Vec::new());
        }
        components[component_of_root[top]].push(index);
    }
    components
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    /// A symmetric band matrix with both triangles stored.
    fn band(n: usize, half_width: usize, random: &mut SplitMix64) -> CscMatrix {
        let mut triplets = Vec::new();
        for j in 0..n {
            for i in j..(j + half_width + 1).min(n) {
                let value = random.next_signed();
                triplets.push((i, j, value));
                if i != j {
                    triplets.push((j, i, value));
                }
            }
        }
        CscMatrix::from_triplets(n, n, triplets)
    }

    #[test]
    fn components_are_the_blocks_no_matrix_couples() {
        // Two matrices on 7 indices: 0-3 and 3-5 in one, 1-6 in the other; 2 and 4 alone.
        let pairs = |edges: &[(usize, usize)]| {
            let mut triplets: Vec<_> = (0..7).map(|i| (i, i, 1.0)).collect();
            for &(i, j) in edges {
                triplets.extend([(i, j, -0.5), (j, i, -0.5)]);
            }
            CscMatrix::from_triplets(7, 7, triplets)
        };
        let (A, B) = (pairs(&[(0, 3), (3, 5)]), pairs(&[(6, 1)]));
        assert_eq!(
            components(&[&A, &B]),
            vec![vec![0, 3, 5], vec![1, 6], vec![2], vec![4]]
        );
        assert_eq!(components(&[&A]).len(), 5);
        let block = A.principal_submatrix(&[0, 3, 5]);
        let dense = A.to_dense();
        for (i, &row) in [0, 3, 5].iter().enumerate() {
            for (j, &col) in [0, 3, 5].iter().enumerate() {
                assert_eq!(block.to_dense()[(i, j)], dense[(row, col)]);
            }
        }
        assert_eq!(block.values.len(), 7);
    }

    #[test]
    fn each_entry_of_the_product_is_one_sequential_sum() {
        let mut random = SplitMix64::new(7);
        let (n, p) = (3 * ROWS_PER_TASK / 2, 141);
        let A = band(n, 5, &mut random);
        let X = Mat::from_fn(n, p, |_, _| random.next_signed());
        let Y = symmetric_mul(&A, X.as_ref());
        // Row `j` of `A X`: column `j` of `A`, in stored order, dotted with `X`'s columns.
        let expected = Mat::from_fn(n, p, |j, k| {
            (A.col_ptr[j]..A.col_ptr[j + 1]).fold(0.0, |sum, entry| {
                sum + A.values[entry] * X[(A.row_idx[entry], k)]
            })
        });
        for k in 0..p {
            for j in 0..n {
                assert_eq!(
                    Y[(j, k)].to_bits(),
                    expected[(j, k)].to_bits(),
                    "({j}, {k})"
                );
            }
        }
        let dense = &A.to_dense() * &X;
        let error = (&Y - &dense).norm_max() / dense.norm_max();
        assert!(error < 1e-14, "against the dense product: {error:.1e}");
        let one = symmetric_mul(&A, X.subcols(5, 1));
        for j in 0..n {
            assert_eq!(
                one[(j, 0)].to_bits(),
                expected[(j, 5)].to_bits(),
                "({j}) alone"
            );
        }
        let rows = symmetric_mul_rows(&A, &[3, n - 1], X.as_ref());
        for k in 0..p {
            assert_eq!(rows[(0, k)].to_bits(), expected[(3, k)].to_bits());
            assert_eq!(rows[(1, k)].to_bits(), expected[(n - 1, k)].to_bits());
        }
        assert_eq!(symmetric_mul(&A, X.subcols(0, 0)).ncols(), 0);
    }
}

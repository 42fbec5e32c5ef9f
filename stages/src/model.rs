//! The assembled finite-element model: sparse mass, stiffness and damping matrices over the
//! free degrees of freedom, and the map from nodes to those DOFs.

use serde::{Deserialize, Serialize};

use crate::mesh::Mesh;

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

/// `M`, `K`, `C = α M + β K` (α, β per part) over the free DOFs.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Model {
    pub mesh: Mesh,
    /// Free DOF index of each node's x, y, z displacement; `None` where clamped.
    pub dof_of_node: Vec<[Option<u32>; 3]>,
    pub M: CscMatrix,
    pub K: CscMatrix,
    pub C: CscMatrix,
}

impl Model {
    pub fn n_dofs(&self) -> usize {
        self.K.n_rows
    }
}

/// Real modes of (K, M): ω², mass-normalised shapes, residuals.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RealModes {
    /// Angular frequencies ω (rad/s), ascending.
    pub omega: Vec<f64>,
    /// Shapes over the free DOFs, one vector per mode, with φᵀ M φ = 1.
    pub shapes: Vec<Vec<f64>>,
    /// ‖K φ − ω² M φ‖ / ‖K φ‖ per mode.
    pub residuals: Vec<f64>,
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

    /// The entries as (row, col, value).
    pub fn triplets(&self) -> impl Iterator<Item = (usize, usize, f64)> + '_ {
        (0..self.n_cols).flat_map(move |col| {
            (self.col_ptr[col]..self.col_ptr[col + 1])
                .map(move |entry| (self.row_idx[entry], col, self.values[entry]))
        })
    }
}

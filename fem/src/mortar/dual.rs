//! The multiplier basis of a slave face: the transformed shape functions N̂ = T N of quadratic
//! faces and the dual basis Φ = A N̂ biorthogonal to them.
// Index loops follow the index notation of the formulas (D = Q G, M̂ = T G Tᵀ).
#![allow(clippy::needless_range_loop)]

use super::geometry::MAX_NODES;
use crate::element::topology::FaceKind;

/// The share α of each mid-edge shape function moved onto the corners of its edge.
pub(super) const ALPHA: f64 = 0.2;

/// N̂ = T N: for quadratic faces, N̂_c = N_c + α (N_m + N_m') over the two mid-edge nodes m, m'
/// of the edges at corner c and N̂_m = (1 − 2α) N_m; for linear faces N̂ = N. T keeps the
/// partition of unity: every mid-edge node gives α to each of its two corners.
pub(super) fn transform(kind: FaceKind, values: &[f64; MAX_NODES]) -> [f64; MAX_NODES] {
    let n_corners = kind.n_corners();
    if kind.n_nodes() == n_corners {
        return *values;
    }
    let mut transformed = [0.0; MAX_NODES];
    for corner in 0..n_corners {
        // Mid-edge node n_corners + e sits on the edge (e, e + 1) of the corner cycle.
        let after = n_corners + corner;
        let before = n_corners + (corner + n_corners - 1) % n_corners;
        transformed[corner] = values[corner] + ALPHA * (values[after] + values[before]);
    }
    for mid in n_corners..kind.n_nodes() {
        transformed[mid] = (1.0 - 2.0 * ALPHA) * values[mid];
    }
    transformed
}

/// The coefficients X (`X[i][j]`, n × n) of the dual basis Φ_j = Σ_i X_ij N̂_i from the face
/// integrals `diagonal[j] = ∫ N̂_j` and `mass[i][j] = ∫ N̂_i N̂_j`: X = M̂⁻¹ D̂ (so that A = Xᵀ =
/// D̂ M̂⁻¹), solved by Gaussian elimination with partial pivoting. `None` if M̂ is singular.
pub(super) fn dual_coefficients(
    n: usize,
    diagonal: &[f64; MAX_NODES],
    mass: &[[f64; MAX_NODES]; MAX_NODES],
) -> Option<[[f64; MAX_NODES]; MAX_NODES]> {
    let mut lu = *mass;
    let mut rhs = [[0.0; MAX_NODES]; MAX_NODES];
    for j in 0..n {
        rhs[j][j] = diagonal[j];
    }
    let scale = (0..n).map(|i| lu[i][i].abs()).fold(0.0, f64::max);
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|&a, &b| lu[a][col].abs().total_cmp(&lu[b][col].abs()))
            .unwrap_or(col);
        if !(lu[pivot][col].abs() > 1e-13 * scale) {
            return None;
        }
        lu.swap(col, pivot);
        rhs.swap(col, pivot);
        for row in col + 1..n {
            let factor = lu[row][col] / lu[col][col];
            for k in col..n {
                lu[row][k] -= factor * lu[col][k];
            }
            for k in 0..n {
                rhs[row][k] -= factor * rhs[col][k];
            }
        }
    }
    let mut X = [[0.0; MAX_NODES]; MAX_NODES];
    for row in (0..n).rev() {
        for k in 0..n {
            let mut sum = rhs[row][k];
            for c in row + 1..n {
                sum -= lu[row][c] * X[c][k];
            }
            X[row][k] = sum / lu[row][row];
        }
    }
    Some(X)
}

/// T as a matrix (`T[i][a]`: N̂_i = Σ_a T_ia N_a).
pub(super) fn matrix(kind: FaceKind) -> [[f64; MAX_NODES]; MAX_NODES] {
    let mut T = [[0.0; MAX_NODES]; MAX_NODES];
    for a in 0..kind.n_nodes() {
        let mut unit = [0.0; MAX_NODES];
        unit[a] = 1.0;
        let column = transform(kind, &unit);
        for i in 0..kind.n_nodes() {
            T[i][a] = column[i];
        }
    }
    T
}

/// Φ_j = Σ_i X_ij N̂_i.
#[cfg(test)]
pub(super) fn evaluate(
    n: usize,
    X: &[[f64; MAX_NODES]; MAX_NODES],
    transformed: &[f64; MAX_NODES],
) -> [f64; MAX_NODES] {
    let mut phi = [0.0; MAX_NODES];
    for i in 0..n {
        for j in 0..n {
            phi[j] += X[i][j] * transformed[i];
        }
    }
    phi
}

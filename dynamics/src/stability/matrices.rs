//! `stability.matrices`: complex eigenvalues of a small model given by its matrices,
//! `(λ² M + λ C + K) x = 0`, read from Matrix Market files (any of them may be non-symmetric:
//! a lumped friction model puts μ straight into K, as Hoffmann et al. 2002 do).
//!
//! Solved densely ([`super::dense`]), so meant for up to `MAX_DOFS` (2,000) DOFs; the residual
//! of each pair is `‖(λ² M + λ C + K) x‖ / ((|λ|² ‖M‖₁ + |λ| ‖C‖₁ + ‖K‖₁) ‖x‖)`. The file reads
//! make the stage impure: it reruns every time, and stages below it still cut off early.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use faer::c64;

use super::figure::stability_diagram;
use super::sliding::{mul_complex, norm};
use super::{EigenPair, complex_mode, conditioning, eigenvalue_table, mode_name};
use crate::artifact::CscMatrix;
use crate::artifact::{Artifact, ArtifactType, ComplexModes};
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError};
use crate::table::Table;
use squeal_linalg::matrix_market::read_matrix_market;

/// Largest model the dense solve accepts.
pub const MAX_DOFS: usize = 2000;

/// Every finite eigenpair with `Im λ ≥ 0` of the dense problem, by increasing frequency, each
/// with its residual; an error if any residual exceeds `tolerance`.
pub fn solve_matrices(
    M: &CscMatrix,
    C: &CscMatrix,
    K: &CscMatrix,
    f_max_hz: f64,
    tolerance: f64,
) -> Result<Vec<EigenPair>, StageError> {
    let n = M.n_rows;
    for (name, A) in [("M", M), ("C", C), ("K", K)] {
        if A.n_rows != n || A.n_cols != n {
            return Err(StageError::new(format!(
                "{name} is {} x {}, M is {n} x {n}: the matrices must be square and of one size",
                A.n_rows, A.n_cols
            )));
        }
    }
    if n == 0 || n > MAX_DOFS {
        return Err(StageError::new(format!(
            "{n} DOFs: the dense solve takes 1 to {MAX_DOFS}"
        )));
    }
    let norms = [M.norm_1(), C.norm_1(), K.norm_1()];
    let mut pairs = dense_pairs(M, C, K, f_max_hz, norms)?;
    // The left vectors: the transposed problem, solved the same way.
    let left_band = f_max_hz * (1.0 + 1e-6);
    let left = dense_pairs(
        &M.transpose(),
        &C.transpose(),
        &K.transpose(),
        left_band,
        norms,
    )?;
    let conditions = conditioning::condition_numbers(&pairs, &left, norms, |lambda, y, x| {
        let (Mx, Cx) = (mul_complex(M, x), mul_complex(C, x));
        y.iter()
            .zip(Mx.iter().zip(&Cx))
            .map(|(y, (m, c))| y * (2.0 * lambda * m + c))
            .sum()
    });
    conditioning::attach(&mut pairs, conditions);
    pairs.sort_by(|a, b| a.lambda.im.total_cmp(&b.lambda.im));
    if let Some(worst) = pairs.iter().find(|pair| !(pair.residual <= tolerance)) {
        return Err(StageError::new(format!(
            "the eigenvalue {:.6e}{:+.6e}i has residual {:.2e} > {tolerance:e}",
            worst.lambda.re, worst.lambda.im, worst.residual
        )));
    }
    Ok(pairs)
}

/// The pairs of the dense problem in the band, with their residuals.
fn dense_pairs(
    M: &CscMatrix,
    C: &CscMatrix,
    K: &CscMatrix,
    f_max_hz: f64,
    norms: [f64; 3],
) -> Result<Vec<EigenPair>, StageError> {
    let n = M.n_rows;
    let omega_max = 2.0 * PI * f_max_hz;
    Ok(super::dense::quadratic_eigen(
        M.to_dense().as_ref(),
        C.to_dense().as_ref(),
        K.to_dense().as_ref(),
        |lambda| lambda.im > 0.0 && (f_max_hz <= 0.0 || lambda.im <= omega_max),
    )?
    .into_iter()
    .map(|(lambda, x)| {
        let (Mx, Cx, Kx) = (mul_complex(M, &x), mul_complex(C, &x), mul_complex(K, &x));
        let r: Vec<c64> = (0..n)
            .map(|i| lambda * lambda * Mx[i] + lambda * Cx[i] + Kx[i])
            .collect();
        let scale = lambda.norm_sqr() * norms[0] + lambda.norm() * norms[1] + norms[2];
        let residual = norm(&r) / (scale * norm(&x)).max(f64::MIN_POSITIVE);
        EigenPair {
            lambda,
            q: x,
            residual,
            condition: f64::NAN,
        }
    })
    .collect())
}

/// `stability.matrices`.
pub struct StabilityMatrices;

crate::stage_params! {
    /// The parameters of `stability.matrices`.
    pub struct MatricesParams {
        /// mass matrix, Matrix Market
        m_path: PathBuf,
        /// damping matrix, Matrix Market (may have no entries)
        c_path: PathBuf,
        /// stiffness matrix (with the friction coupling, or without it when kf_path is given),
        /// Matrix Market
        k_path: PathBuf,
        /// friction coupling per unit mu, Matrix Market: the stiffness is K + mu Kf (sweep mu
        /// through a mode coupling)
        kf_path: Option<PathBuf> = None,
        /// top of the band; 0 keeps every mode
        #[unit = "Hz"]
        #[min = 0.0]
        f_max_hz: f64 = 0.0,
        /// friction coefficient: multiplies kf_path; without it, the one the matrices were built
        /// with (labels only)
        #[min = 0.0]
        mu: f64 = 0.0,
    }
}

impl HasParams for StabilityMatrices {
    type Params = MatricesParams;
}

impl Stage for StabilityMatrices {
    fn kind(&self) -> &'static str {
        "stability.matrices"
    }
    fn version(&self) -> u32 {
        // 3: the `modes` output (CHANGELOG.md, "stability.matrices")
        3
    }
    fn doc(&self) -> &'static str {
        "Complex eigenvalues of a small model from Matrix Market M, C, K (dense; lumped friction models)"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        Vec::new()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "eigenvalues",
                ArtifactType::Table,
                "mode, freq_hz, re, im, divergence_rate, unstable, residual, condition, error_bound",
            ),
            PortSpec::one(
                "shapes",
                ArtifactType::Table,
                "one row per DOF (`dof`), mode_NNNN_re and mode_NNNN_im columns, each shape of unit norm",
            ),
            PortSpec::one(
                "modes",
                ArtifactType::ComplexModes,
                "every eigenvalue with its residual, κ and unit shape: what stability.track follows",
            ),
            PortSpec::one(
                "diagram",
                ArtifactType::Figure,
                "stability diagram: divergence rate against frequency",
            ),
        ]
    }
    fn pure(&self) -> bool {
        false
    }
    fn run(&self, params: &Params, _inputs: &Inputs) -> Result<Outputs, StageError> {
        let params = params.read::<Self>()?;
        let read = |path: &Path| -> Result<CscMatrix, StageError> {
            let failed =
                |err: &dyn std::fmt::Display| StageError::new(format!("{}: {err}", path.display()));
            let text = std::fs::read_to_string(path).map_err(|err| failed(&err))?;
            read_matrix_market(&text).map_err(|err| failed(&err))
        };
        let (M, C, mut K) = (
            read(&params.m_path)?,
            read(&params.c_path)?,
            read(&params.k_path)?,
        );
        if let Some(kf_path) = &params.kf_path {
            let friction = read(kf_path)?;
            if (friction.n_rows, friction.n_cols) != (K.n_rows, K.n_cols) {
                return Err(StageError::new(format!(
                    "{}: {} x {}, K is {} x {}: the matrices must be of one size",
                    kf_path.display(),
                    friction.n_rows,
                    friction.n_cols,
                    K.n_rows,
                    K.n_cols
                )));
            }
            K = CscMatrix::from_triplets(
                K.n_rows,
                K.n_cols,
                K.triplets()
                    .chain(
                        friction
                            .triplets()
                            .map(|(row, col, value)| (row, col, params.mu * value)),
                    )
                    .collect(),
            );
        }
        let pairs = solve_matrices(&M, &C, &K, params.f_max_hz, 1e-8)?;
        let diagram = stability_diagram(&pairs, params.mu)?;
        let n = M.n_rows;
        let mut shapes = Table::new().with("dof", (0..n as i64).collect::<Vec<i64>>());
        let mut modes = Vec::with_capacity(pairs.len());
        for (mode, pair) in pairs.iter().enumerate() {
            // Unit norm, the largest component real and positive: one shape per mode, whatever
            // phase the solver returned.
            let largest = pair
                .q
                .iter()
                .copied()
                .max_by(|a, b| a.norm().total_cmp(&b.norm()))
                .unwrap_or(c64::new(1.0, 0.0));
            let scale = largest.conj() / (largest.norm() * norm(&pair.q)).max(f64::MIN_POSITIVE);
            let shape: Vec<c64> = pair.q.iter().map(|value| value * scale).collect();
            let re: Vec<f64> = shape.iter().map(|value| value.re).collect();
            let im: Vec<f64> = shape.iter().map(|value| value.im).collect();
            shapes = shapes
                .with(format!("{}_re", mode_name(mode)), re.clone())
                .with(format!("{}_im", mode_name(mode)), im.clone());
            modes.push(complex_mode(mode, pair, Some((re, im))));
        }
        Ok(Outputs::from([
            (
                "eigenvalues".to_string(),
                Artifact::Table(eigenvalue_table(&pairs)),
            ),
            ("shapes".to_string(), Artifact::Table(shapes)),
            (
                "modes".to_string(),
                Artifact::ComplexModes(Box::new(ComplexModes { modes })),
            ),
            ("diagram".to_string(), Artifact::Figure(diagram)),
        ]))
    }
}

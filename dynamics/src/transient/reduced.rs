//! The transient on a reduction basis ([`crate::basis`]): the same scheme on
//! `(Tᵀ M T, Tᵀ C T, Tᵀ K T)` in the coordinates `x = [u_i; q]`. The interface DOFs are
//! coordinates of `x`, so `H` keeps its entries, renumbered; the departure from the
//! equilibrium starts at `x⁰ = [u⁰_i; Φᵀ M (u⁰ − S u⁰_i)]`, and the snapshots are lifted back
//! to every DOF, `u = T x`. The blocks of `Tᵀ K T` between the interface and the vectors are
//! zero (`φᵀ K S = 0` for `φ` vanishing on the interface, and the basis stage sets them so),
//! and a step's products skip them with the matrices' other exact zeros.
//!
//! # The residual indicator
//!
//! The reduced step is the Galerkin projection of the full one: with the lifted states
//! `u⁰ = T x⁰`, `v⁰ = T ẋ⁰`, `v¹ = T ẋ¹` and the step's reactions `r`, the residual of the
//! full step equation
//!
//! ```text
//! R = M (v¹ − v⁰)/τ + C v^θ + K u^θ − Hᵀ (r − r_e),   u^θ = u⁰ + τθ v^θ
//! ```
//!
//! satisfies `Tᵀ R = 0` exactly: it is what the basis cannot represent of the full dynamics at
//! that step. `δv = J⁻¹ R` is the velocity correction the full scheme would make from the
//! same state (`J` the full model's), and the indicator compares it with the step's own change
//! of velocity over the sampled steps,
//!
//! ```text
//! η = ( Σ_k ‖δv_k‖²_M / Σ_k ‖v¹_k − v⁰_k‖²_M )^½
//! ```
//!
//! dimensionless, zero for a basis that spans every DOF, and computed from the reduced run
//! alone (one factorisation of the full `J` and one solve per sampled step, no full run).
//! `indicator_samples: 0` skips it.

use faer::{Mat, Par};

use super::scheme::{self, ContactState, Load, Run, StepSample, Structure};
use crate::artifact::{Basis, CscMatrix, Model};
use crate::stage::StageError;
use squeal_linalg::cholesky::Cholesky;
use squeal_linalg::csc::symmetric_mul;

/// The reduced matrices and `H` on the reduced coordinates.
pub struct ReducedModel<'a> {
    pub M: &'a CscMatrix,
    pub C: &'a CscMatrix,
    pub K: &'a CscMatrix,
    /// `H` on the reduced coordinates.
    pub H_rows: Vec<Vec<(usize, f64)>>,
}

impl<'a> ReducedModel<'a> {
    /// `full`: the full model's structure (its `H`).
    pub fn new(
        model: &Model,
        basis: &'a Basis,
        full: &Structure,
    ) -> Result<ReducedModel<'a>, StageError> {
        let foreign = |what: String| {
            Err(StageError::new(format!(
                "transient: the basis does not belong to this model: {what}"
            )))
        };
        if let Err(what) = basis.check_fits(model.n_dofs()) {
            return foreign(what);
        }
        let position = |dof: usize| basis.interface.binary_search(&(dof as u32)).ok();
        let H_rows = full
            .H_rows
            .iter()
            .map(|row| {
                row.iter()
                    .map(|&(dof, value)| position(dof).map(|index| (index, value)))
                    .collect::<Option<Vec<_>>>()
            })
            .collect::<Option<Vec<_>>>();
        let Some(H_rows) = H_rows else {
            return foreign("a contact DOF is not on its interface".to_string());
        };
        Ok(ReducedModel {
            M: &basis.mass,
            C: &basis.damping,
            K: &basis.stiffness,
            H_rows,
        })
    }

    /// The structure the scheme integrates.
    pub fn structure(&self) -> Structure<'_> {
        Structure {
            M: self.M,
            C: self.C,
            K: self.K,
            dof_of_node: &[],
            H_rows: self.H_rows.clone(),
            load: Load::default(),
        }
    }
}

/// Every snapshot's `u` and `v` lifted to the full DOFs.
pub fn lift_snapshots(basis: &Basis, run: &mut Run) {
    // The displacements and the velocities side by side: one pass over the vectors.
    let (n_r, p) = (basis.n_reduced(), run.snapshots.len());
    let X = Mat::from_fn(n_r, 2 * p, |i, k| {
        let snapshot = &run.snapshots[k % p];
        if k < p { snapshot.u[i] } else { snapshot.v[i] }
    });
    let UV = basis.lift(X.as_ref());
    for (k, snapshot) in run.snapshots.iter_mut().enumerate() {
        snapshot.u = UV.col(k).iter().copied().collect();
        snapshot.v = UV.col(p + k).iter().copied().collect();
    }
}

/// The residual indicator of a reduced run (see the module doc).
pub struct Indicator {
    /// `η` over every sampled step.
    pub value: f64,
    /// `(t, η_k)` per sampled step.
    pub per_step: Vec<(f64, f64)>,
    /// The residuals `R_k` and the corrections `δv_k = J⁻¹ R_k`, one column per sampled
    /// step, over the full DOFs.
    pub residuals: Mat<f64>,
    pub corrections: Mat<f64>,
}

/// The full model's `J`, factorised once to check reduced runs against it.
pub struct FullStep {
    cholesky: Cholesky,
    theta: f64,
    tau: f64,
}

impl FullStep {
    pub fn new(full: &Structure, theta: f64, tau: f64) -> Result<FullStep, StageError> {
        let cholesky = scheme::factorise_J(full, theta, tau).map_err(|err| {
            StageError::new(format!(
                "transient: the full J for the residual indicator: {err}"
            ))
        })?;
        Ok(FullStep {
            cholesky,
            theta,
            tau,
        })
    }

    /// The indicator of a reduced run's sampled steps.
    pub fn indicator(
        &self,
        basis: &Basis,
        full: &Structure,
        contact_state: &ContactState,
        samples: &[StepSample],
    ) -> Indicator {
        let (theta, tau) = (self.theta, self.tau);
        let n_r = basis.n_reduced();
        let n = full.K.n_rows;
        let X = Mat::from_fn(n_r, 3 * samples.len(), |i, k| {
            let sample = &samples[k / 3];
            [&sample.u_old, &sample.v_old, &sample.v_new][k % 3][i]
        });
        let lifted = basis.lift(X.as_ref());
        let mut dv = Mat::<f64>::zeros(n, samples.len());
        let mut v_theta = Mat::<f64>::zeros(n, samples.len());
        let mut u_theta = Mat::<f64>::zeros(n, samples.len());
        for k in 0..samples.len() {
            for i in 0..n {
                let (u0, v0, v1) = (
                    lifted[(i, 3 * k)],
                    lifted[(i, 3 * k + 1)],
                    lifted[(i, 3 * k + 2)],
                );
                let vt = theta * v1 + (1.0 - theta) * v0;
                dv[(i, k)] = v1 - v0;
                v_theta[(i, k)] = vt;
                u_theta[(i, k)] = u0 + tau * theta * vt;
            }
        }
        let M_dv = symmetric_mul(full.M, dv.as_ref());
        let C_v = symmetric_mul(full.C, v_theta.as_ref());
        let K_u = symmetric_mul(full.K, u_theta.as_ref());
        let mut residuals = Mat::from_fn(n, samples.len(), |i, k| {
            M_dv[(i, k)] / tau + C_v[(i, k)] + K_u[(i, k)]
        });
        for (k, sample) in samples.iter().enumerate() {
            for (row, entries) in full.H_rows.iter().enumerate() {
                let reaction = sample.r[row] - contact_state.r_e[row];
                for &(dof, value) in entries {
                    residuals[(dof, k)] -= value * reaction;
                }
            }
        }
        let mut correction = residuals.clone();
        self.cholesky.solve_in_place(correction.as_mut(), Par::Seq);
        let M_correction = symmetric_mul(full.M, correction.as_ref());
        let m_norm_squared = |A: &Mat<f64>, MA: &Mat<f64>, k: usize| -> f64 {
            A.col(k)
                .iter()
                .zip(MA.col(k).iter())
                .map(|(a, b)| a * b)
                .sum()
        };
        let (mut defect, mut change) = (0.0, 0.0);
        let per_step = samples
            .iter()
            .enumerate()
            .map(|(k, sample)| {
                let d = m_norm_squared(&correction, &M_correction, k);
                let c = m_norm_squared(&dv, &M_dv, k);
                defect += d;
                change += c;
                let ratio = if c > 0.0 { (d / c).sqrt() } else { 0.0 };
                (sample.step as f64 * tau, ratio)
            })
            .collect();
        Indicator {
            value: if change > 0.0 {
                (defect / change).sqrt()
            } else {
                0.0
            },
            per_step,
            residuals,
            corrections: correction,
        }
    }
}

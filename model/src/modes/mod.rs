//! `modes`: real modes of the undamped model, `K φ = ω² M φ`.
//!
//! The lowest `n_modes` eigenpairs with frequency in `[shift_hz, f_max_hz]` (or all of them up
//! to `f_max_hz` when `n_modes = 0`), by block shift-invert Lanczos on a sparse LDLᵀ of
//! `K − σ M` ([`eigensolver`]). Every reported mode has
//!
//! ```text
//! φᵀ M φ = 1,    ‖K φ − ω² M φ‖ / ‖K φ‖ ≤ 1e-8
//! ```
//!
//! and the set is proved complete by Sylvester's law of inertia: the negative pivots of
//! LDLᵀ(K − τ M) count the eigenvalues below τ (`factor`). A failed proof or an inaccurate
//! mode is an error with the figures, never a silently wrong answer. (A rigid-body mode, where
//! `K φ = 0`, is measured by its backward error instead: see [`eigensolver`].) Results are
//! bit-identical from run to run and whatever the number of threads.
//!
//! The table gives, per mode, the participation factors `Γ_d = φᵀ M r_d` of the rigid
//! translations `r_d` (d = x, y, z) and the effective masses `Γ_d²` (kg): the share of the
//! (free) mass each mode moves along each axis.

#[cfg(test)]
mod tests;

use faer::Mat;

use crate::artifact::{Artifact, ArtifactType};
use crate::artifact::{Model, RealModes};
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError};
use crate::table::Table;

use squeal_linalg::eigensolver::{self, Band, Eigensolution, SolveOptions};

/// `modes`: model → real modes, a table per mode and the wide table of mode shapes.
pub struct Modes;

impl HasParams for Modes {
    type Params = ModesParams;
}

impl Stage for Modes {
    fn kind(&self) -> &'static str {
        "modes"
    }

    fn version(&self) -> u32 {
        1
    }

    fn doc(&self) -> &'static str {
        "Real modes K phi = omega^2 M phi by shift-invert block Lanczos, completeness proved by a Sturm count"
    }

    fn inputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "model",
            ArtifactType::Model,
            "M and K over the free DOFs",
        )]
    }

    fn renamed_outputs(&self) -> &'static [(&'static str, &'static str)] {
        &[("table", "frequencies")]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "modes",
                ArtifactType::RealModes,
                "omega, mass-normalised shapes, residuals",
            ),
            PortSpec::one(
                "frequencies",
                ArtifactType::Table,
                "per mode: frequency, omega, residual, participation and effective mass along x, y, z",
            ),
            PortSpec::one(
                "shapes",
                ArtifactType::Table,
                "one row per node and direction, one column per mode (mode_0001, ...)",
            ),
        ]
    }

    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let model: &Model = inputs.get("model")?;
        let band = band_from_params(params)?;
        let solution = eigensolver::solve(
            &model.K,
            &model.M,
            &model.dof_of_node,
            band,
            SolveOptions::default(),
        )?;
        let table = modes_table(model, &solution);
        let shapes = shapes_table(model, &solution.shapes);
        let modes = real_modes(solution);
        Ok(Outputs::from([
            ("modes".to_string(), Artifact::RealModes(Box::new(modes))),
            ("frequencies".to_string(), Artifact::Table(table)),
            ("shapes".to_string(), Artifact::Table(shapes)),
        ]))
    }
}

crate::stage_params! {
    /// The parameters of `modes`.
    pub struct ModesParams {
        /// number of modes, lowest first; 0 means every mode up to f_max_hz
        #[min = 0]
        n_modes: usize = 20,
        /// highest frequency wanted; 0 means no upper bound
        #[unit = "Hz"]
        #[min = 0.0]
        f_max_hz: f64 = 0.0,
        /// lowest frequency wanted (the spectral shift); 0 includes rigid-body modes
        #[unit = "Hz"]
        #[min = 0.0]
        shift_hz: f64 = 0.0,
    }
}

/// The wanted band from the stage parameters, as eigenvalues λ = ω² = (2π f)².
pub fn band_from_params(params: &Params) -> Result<Band, StageError> {
    let ModesParams {
        n_modes,
        f_max_hz,
        shift_hz,
    } = params.read::<Modes>()?;
    if !(f_max_hz >= 0.0) || !(shift_hz >= 0.0) {
        return Err(StageError::new(format!(
            "f_max_hz = {f_max_hz}, shift_hz = {shift_hz}: neither may be negative"
        )));
    }
    if n_modes == 0 && f_max_hz == 0.0 {
        return Err(StageError::new(
            "n_modes = 0 asks for every mode up to f_max_hz, but f_max_hz = 0 (unset)",
        ));
    }
    if f_max_hz > 0.0 && f_max_hz <= shift_hz {
        return Err(StageError::new(format!(
            "f_max_hz = {f_max_hz} Hz is not above shift_hz = {shift_hz} Hz: the band is empty"
        )));
    }
    let lambda = |frequency_hz: f64| (2.0 * std::f64::consts::PI * frequency_hz).powi(2);
    Ok(Band {
        n_modes,
        lambda_lo: lambda(shift_hz),
        lambda_hi: if f_max_hz > 0.0 {
            lambda(f_max_hz)
        } else {
            f64::INFINITY
        },
    })
}

/// ω from λ = ω², signed so that a (roundoff) negative eigenvalue stays visible.
pub fn omega_of(lambda: f64) -> f64 {
    lambda.signum() * lambda.abs().sqrt()
}

fn real_modes(solution: Eigensolution) -> RealModes {
    let shapes = (0..solution.shapes.ncols())
        .map(|j| solution.shapes.col(j).iter().copied().collect())
        .collect();
    RealModes {
        omega: solution
            .lambda
            .iter()
            .map(|&lambda| omega_of(lambda))
            .collect(),
        shapes,
        residuals: solution.residuals,
    }
}

/// Direction (0, 1, 2) of each free DOF, from `dof_of_node` (`None` if it does not say).
fn dof_directions(model: &Model) -> Vec<Option<usize>> {
    let mut directions = vec![None; model.n_dofs()];
    for dofs in &model.dof_of_node {
        for (direction, dof) in dofs.iter().enumerate() {
            if let Some(slot) = dof.and_then(|dof| directions.get_mut(dof as usize)) {
                *slot = Some(direction);
            }
        }
    }
    directions
}

fn modes_table(model: &Model, solution: &Eigensolution) -> Table {
    let n_modes = solution.lambda.len();
    let omega: Vec<f64> = solution
        .lambda
        .iter()
        .map(|&lambda| omega_of(lambda))
        .collect();
    let frequency: Vec<f64> = omega
        .iter()
        .map(|omega| omega / (2.0 * std::f64::consts::PI))
        .collect();
    // Γ_d = φᵀ M r_d with r_d the unit rigid translation along d.
    let directions = dof_directions(model);
    let translations = Mat::from_fn(model.n_dofs(), 3, |dof, direction| {
        if directions[dof] == Some(direction) {
            1.0
        } else {
            0.0
        }
    });
    let M_translations = squeal_linalg::csc::symmetric_mul(&model.M, translations.as_ref());
    let participation: Vec<[f64; 3]> = (0..n_modes)
        .map(|mode| {
            std::array::from_fn(|direction| {
                solution
                    .shapes
                    .col(mode)
                    .iter()
                    .zip(M_translations.col(direction).iter())
                    .map(|(phi, m)| phi * m)
                    .sum()
            })
        })
        .collect();
    let column = |direction: usize, squared: bool| -> Vec<f64> {
        participation
            .iter()
            .map(|gamma| {
                if squared {
                    gamma[direction] * gamma[direction]
                } else {
                    gamma[direction]
                }
            })
            .collect()
    };
    Table::new()
        .with("mode", (1..=n_modes as i64).collect::<Vec<i64>>())
        .with("freq_hz", frequency)
        .with("omega", omega)
        .with("residual", solution.residuals.clone())
        .with("participation_x", column(0, false))
        .with("participation_y", column(1, false))
        .with("participation_z", column(2, false))
        .with("effective_mass_x_kg", column(0, true))
        .with("effective_mass_y_kg", column(1, true))
        .with("effective_mass_z_kg", column(2, true))
}

/// Name of the shape column of mode `mode` (0-based): `mode_0001`, ...
pub fn shape_column_name(mode: usize) -> String {
    format!("mode_{:04}", mode + 1)
}

/// One row per node and direction (clamped DOFs included, with zeros), one column per mode.
fn shapes_table(model: &Model, shapes: &Mat<f64>) -> Table {
    model.nodal_table(
        (0..shapes.ncols())
            .map(|mode| {
                (
                    shape_column_name(mode),
                    shapes.col(mode).iter().copied().collect(),
                )
            })
            .collect(),
    )
}

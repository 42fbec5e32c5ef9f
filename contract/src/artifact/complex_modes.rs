//! Complex modes of a linearised system, as the stability stages solved them: every eigenvalue
//! of the band with its residual and condition number, and the right shapes the stage kept.
//!
//! For `λ = σ + iω` the frequency is `ω / 2π` and the mode is unstable when
//! `σ > UNSTABLE_FLOOR · |λ|` ([`is_unstable`]: a neutral mode's round-off is not growth). Shapes are over the
//! model's free DOFs; how a producer normalises them is in its doc (`stability`: mass-unit,
//! largest component real; `stability.matrices`: unit Euclidean norm). Left vectors are not
//! kept: they are the condensed sliding problem's, in its coordinates, and enter only the
//! condition numbers.

use std::f64::consts::PI;

use faer::{Mat, c64};
use serde::{Deserialize, Serialize};

use crate::value::StageError;

/// `Re λ > UNSTABLE_FLOOR · |λ|` marks an unstable mode.
pub const UNSTABLE_FLOOR: f64 = 1e-8;

pub fn is_unstable(lambda: c64) -> bool {
    lambda.re > UNSTABLE_FLOOR * lambda.norm()
}

/// The complex modes of one stability solve, in ascending frequency (the eigenvalue table's
/// order: `number` is its `mode` column).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ComplexModes {
    pub modes: Vec<ComplexMode>,
}

/// One eigenpair.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ComplexMode {
    /// 1-based rank in the band, as in the stage's tables (`mode_NNNN_re`).
    pub number: i64,
    /// Real part of λ: the divergence rate is `2 re / im`.
    pub re: f64,
    /// Imaginary part of λ (rad/s).
    pub im: f64,
    /// The pair's backward error (the tables' `residual`).
    pub residual: f64,
    /// κ(λ); NaN where it was not computed.
    pub condition: f64,
    /// The right shape over the model's free DOFs, when the stage kept it.
    pub shape: Option<ComplexShape>,
}

/// A complex vector as its real and imaginary parts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ComplexShape {
    pub re: Vec<f64>,
    pub im: Vec<f64>,
}

impl ComplexMode {
    pub fn freq_hz(&self) -> f64 {
        self.im / (2.0 * PI)
    }

    pub fn is_unstable(&self) -> bool {
        is_unstable(c64::new(self.re, self.im))
    }
}

/// The modes that have a shape, with their shapes as columns of two matrices.
pub struct ShapeMatrices<'a> {
    pub modes: Vec<&'a ComplexMode>,
    pub re: Mat<f64>,
    pub im: Mat<f64>,
}

impl ComplexModes {
    /// The modes whose shape was kept.
    pub fn with_shapes(&self) -> impl Iterator<Item = (&ComplexMode, &ComplexShape)> {
        self.modes
            .iter()
            .filter_map(|mode| mode.shape.as_ref().map(|shape| (mode, shape)))
    }

    /// The mode numbered `number`.
    pub fn get(&self, number: i64) -> Option<&ComplexMode> {
        self.modes.iter().find(|mode| mode.number == number)
    }

    /// Every kept shape as a column of `n_rows` values: row `r` holds DOF `dof_of_row[r]`, or
    /// zero where it is `None` (a clamped direction of a nodal table).
    pub fn shape_matrices(
        &self,
        n_rows: usize,
        dof_of_row: &[Option<usize>],
    ) -> Result<ShapeMatrices<'_>, StageError> {
        let (modes, shapes): (Vec<&ComplexMode>, Vec<&ComplexShape>) = self.with_shapes().unzip();
        if modes.is_empty() {
            return Err(StageError::new(
                "modes: no mode shape to take (did the stability stage find none in its band, or keep `shapes: unstable` with none unstable?)",
            ));
        }
        let mut re = Mat::<f64>::zeros(n_rows, modes.len());
        let mut im = Mat::<f64>::zeros(n_rows, modes.len());
        for (col, (mode, shape)) in modes.iter().zip(&shapes).enumerate() {
            for (row, dof) in dof_of_row.iter().enumerate() {
                let Some(dof) = *dof else { continue };
                if dof >= shape.re.len() {
                    return Err(StageError::new(format!(
                        "modes: mode {} has {} DOFs, DOF {dof} was asked for: the modes come from another model",
                        mode.number,
                        shape.re.len()
                    )));
                }
                re[(row, col)] = shape.re[dof];
                im[(row, col)] = shape.im[dof];
            }
        }
        Ok(ShapeMatrices { modes, re, im })
    }

    /// Checks that every kept shape has `n_dofs` values in each part.
    pub fn check_dofs(&self, n_dofs: usize) -> Result<(), StageError> {
        for (mode, shape) in self.with_shapes() {
            if shape.re.len() != n_dofs || shape.im.len() != n_dofs {
                return Err(StageError::new(format!(
                    "modes: mode {} has {} DOFs, the model has {n_dofs}: the modes come from another model's stability stage",
                    mode.number,
                    shape.re.len()
                )));
            }
        }
        Ok(())
    }
}

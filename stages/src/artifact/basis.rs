//! A reduction basis and the reduced matrices of a model on it.

use serde::{Deserialize, Serialize};

/// `u = T x` with `x = [u_i; q]`: the interface DOFs `u_i` (every free DOF of the contact
/// pairs' nodes) kept as they are, with their static modes, and the weights `q` of vectors
/// `Φ` that vanish on the interface:
///
/// ```text
/// T = [[I, 0], [Ψ_o, Φ_o]],   Ψ_o = −K_oo⁻¹ K_oi,   Φᵀ M Φ = I
/// ```
///
/// (`o`: the other DOFs). `Ψ_o` is not stored: it follows from the model (see
/// [`crate::basis::StaticModes`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Basis {
    /// Which family the vectors come from (`fc`, `real`, `craig_bampton`, `modes`).
    pub kind: String,
    /// The interface DOFs, ascending: the first coordinates of `x`.
    pub interface: Vec<u32>,
    /// `Φ` over the free DOFs, one vector per column of `T` after the interface's.
    pub vectors: Vec<Vec<f64>>,
    /// `Tᵀ M T`, `Tᵀ C T`, `Tᵀ K T`: dense, column-major, of size [`Basis::n_reduced`].
    pub mass: Vec<f64>,
    pub damping: Vec<f64>,
    pub stiffness: Vec<f64>,
}

impl Basis {
    /// Coordinates of the reduced model: interface DOFs plus vectors.
    pub fn n_reduced(&self) -> usize {
        self.interface.len() + self.vectors.len()
    }
}

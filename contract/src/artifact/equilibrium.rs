//! The sliding equilibrium and the contact frames it was solved in (conventions in
//! the stages' `contact` module).

use serde::{Deserialize, Serialize};

use super::Model;
use crate::value::StageError;

/// The local frame and sliding speed of every contact pair.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ContactFrames {
    pub n: Vec<[f64; 3]>,
    pub t: Vec<[f64; 3]>,
    pub b: Vec<[f64; 3]>,
    /// |v_g| (m/s) at each pair.
    pub sliding_speed: Vec<f64>,
}

/// The sliding equilibrium, as the stability analysis needs it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Equilibrium {
    /// Displacement over the model's free DOFs (m): rigid pad approach excluded under an
    /// interference, included (the floating pads' rigid motions) under a pressure.
    pub u: Vec<f64>,
    /// Normal reaction per pair (N, ≥ 0); r_t = μ r_n on closed pairs, r_b = 0.
    pub r_n: Vec<f64>,
    /// Normal gap per pair (m).
    pub gap: Vec<f64>,
    /// Effective contact zone: pairs in contact.
    pub closed: Vec<bool>,
    pub frames: ContactFrames,
    pub mu: f64,
    pub omega: f64,
}

impl Equilibrium {
    /// An error unless the equilibrium has `model`'s DOFs and contact pairs (one wired from
    /// another model's stage would be read as this one's).
    pub fn check_belongs_to(&self, model: &Model) -> Result<(), StageError> {
        let n_pairs = model.mesh.contact_pairs.len();
        let frames = &self.frames;
        let pair_lengths = [
            self.r_n.len(),
            self.gap.len(),
            self.closed.len(),
            frames.n.len(),
            frames.t.len(),
            frames.b.len(),
            frames.sliding_speed.len(),
        ];
        if self.u.len() != model.n_dofs() || pair_lengths.iter().any(|&len| len != n_pairs) {
            return Err(StageError::new(format!(
                "the equilibrium does not belong to this model: it has {} DOFs and {} contact pairs, the model {} and {n_pairs}; wire the equilibrium stage's `model` input to this stage's model",
                self.u.len(),
                self.r_n.len(),
                model.n_dofs()
            )));
        }
        Ok(())
    }
}

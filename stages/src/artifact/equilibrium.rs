//! The sliding equilibrium and the contact frames it was solved in (conventions in
//! [`crate::contact`]).

use serde::{Deserialize, Serialize};

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

//! The stages that build a model: meshes (the parametric brake, structured blocks, Gmsh,
//! Abaqus and Nastran decks), materials, the assembly of `M`, `K`, `C`, the real modes, and the
//! exports other tools read (VTU, Matrix Market).
//!
//! A stage is a pure function of its parameters and input artifacts
//! ([`squeal_contract::Stage`]); the element kernels are in `squeal-fem`.

#![allow(non_snake_case)]
// `!(x > 0.0)` is how numerical checks reject NaN together with x <= 0.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use squeal_contract::{artifact, choice, params, stage, stage_params, table, value};
use squeal_fem::{self as fem, vtu_writer};

pub mod assemble;
pub mod export;
pub mod material;
pub mod mesh;
pub mod modes;

// The brakes and models the unit tests of this crate and of `squeal-dynamics` start from:
// compiled always (a few small functions), so that a test build of one crate and of the
// workspace build this crate alike.
pub mod fixtures;

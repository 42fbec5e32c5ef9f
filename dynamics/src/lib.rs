//! The stages of frictional dynamics: the Signorini–Coulomb contact laws and their solvers
//! ([`contact`]), the sliding equilibrium, the stability about it (complex modes), reduction
//! bases, and the non-smooth transient on the full or a reduced model.
//!
//! These stages read a model (`squeal-model`) only through the artifacts the engine hands
//! them, so this crate does not depend on that one: an edit to a mesh reader or the assembly
//! does not rebuild the dynamics.

#![allow(non_snake_case)]
// `!(x > 0.0)` is how numerical checks reject NaN together with x <= 0.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use squeal_contract::{artifact, choice, stage, stage_params, table, value};
use squeal_fem::{self as fem, vtu_writer};
use squeal_plot as plot;

pub mod basis;
pub mod contact;
pub mod equilibrium;
pub mod stability;
pub mod transient;

#[cfg(test)]
mod fixtures;
#[cfg(test)]
use squeal_contract::params;
#[cfg(test)]
use squeal_model::{mesh, modes};

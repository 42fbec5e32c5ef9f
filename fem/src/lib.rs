//! Finite-element kernels shared by the stages: the elements (shape functions, quadrature,
//! element matrices, the elasticity an element sees), their faces, the mortar operators that
//! join two non-matching surfaces ([`mortar`]), and the VTU cells every stage with a mesh
//! output writes. The materials' laws are in
//! [`squeal_contract::artifact::material`].
//!
//! This crate knows meshes and materials but no stage: the model's and the dynamics' stages
//! (`squeal-model`, `squeal-dynamics`) both build on it and not on each other.

#![allow(non_snake_case)]
// `!(x > 0.0)` is how numerical checks reject NaN together with x <= 0.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use squeal_contract::{artifact, value};

pub mod element;
pub mod faces;
pub mod mortar;
pub mod vtu_writer;

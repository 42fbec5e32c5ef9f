//! Finite-element kernels shared by the stages: the elements (shape functions, quadrature,
//! element matrices) and their faces. The materials' laws are in
//! [`crate::artifact::material`].

pub mod element;
pub mod faces;

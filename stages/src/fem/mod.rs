//! Finite-element kernels shared by the stages: the elements (shape functions, quadrature,
//! element matrices), their faces, and the mortar operators that tie two non-matching surfaces
//! ([`mortar`]). The materials' laws are in [`crate::artifact::material`].

pub mod element;
pub mod faces;
pub mod mortar;

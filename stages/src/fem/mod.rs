//! Finite-element kernels shared by the stages: the hexahedron (shape functions, Jacobian,
//! element matrices, faces), the materials (Hooke's law, Rayleigh damping, density per part)
//! and orthotropic elasticity with the frames that orient it.

pub mod element;
pub mod faces;
pub mod material;
pub mod orthotropic;

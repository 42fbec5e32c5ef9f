//! Finite-element kernels shared by the stages: the hexahedron (shape functions, Jacobian,
//! element matrices, faces) and the materials (Hooke's law, Rayleigh damping, density per part).

pub mod faces;
pub mod hex8;
pub mod material;

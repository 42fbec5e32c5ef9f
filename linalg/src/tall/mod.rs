//! Products of a tall matrix `Q` (tens of thousands of rows, up to a thousand columns) with a
//! few columns: the projections and updates of Gram–Schmidt, and bases rebuilt from their
//! coordinates.
//!
//! Real ([`real`]) for the Lanczos basis, complex ([`complex`]) for the Arnoldi basis.

pub mod complex;
pub mod real;

pub use complex::{add_times, adjoint_times, subtract_then_adjoint_times};
pub use real::{add_product, times, transpose_times};

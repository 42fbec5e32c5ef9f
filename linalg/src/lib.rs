//! squeal's linear algebra: sparse matrices and their orderings, symmetric factorisations of
//! a combination `Σ cᵢ Aᵢ` over one pattern, Krylov eigensolvers (Lanczos, Arnoldi/TOAR),
//! Gram–Schmidt, tall-skinny products, dense helpers and Matrix Market text.
//!
//! It knows nothing of meshes, contact, stages or files other than the matrix formats it reads.
//! Parallelism is an explicit argument ([`faer::Par`]): inside an outer parallel loop, pass
//! `Par::Seq`. Every reduction is done over fixed chunks in a fixed order, so results are
//! bit-identical whatever the thread count.

#![allow(non_snake_case)]
// matrices are named as in the equations: M, K, C
// `!(x > 0.0)` is how numerical checks reject NaN together with x <= 0.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod cholesky;
pub mod csc;
pub mod dense;
pub mod eigensolver;
pub mod gram_schmidt;
pub mod lanczos;
pub mod lblt;
pub mod ldlt;
pub mod matrix_market;
pub mod ordering;
pub mod rng;
pub mod tall;
pub mod toar;

pub use csc::CscMatrix;

/// Why a linear-algebra call failed: one line with the figures that matter.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Error {
    /// The caller's matrices or request cannot be used (wrong size, not symmetric, not
    /// finite, an empty band).
    #[error("{0}")]
    InvalidInput(String),
    /// A factorisation or decomposition broke down (singular, not definite, a failed check
    /// solve).
    #[error("{0}")]
    Breakdown(String),
    /// An iteration fell short, or a completeness count disagreed with what was found.
    #[error("{0}")]
    NotConverged(String),
    /// A matrix file could not be read; the message names the line.
    #[error("{0}")]
    Parse(String),
}

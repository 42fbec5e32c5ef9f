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

use faer::Par;

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
pub mod sweeps;
pub mod tall;
pub mod toar;

pub use csc::CscMatrix;

/// Tasks of squeal's parallel kernels, whatever the number of threads.
pub const TASKS: usize = 4;

/// The parallelism to hand faer and the kernels here: a fixed number of tasks ([`TASKS`]),
/// which rayon runs on however many threads there are. faer cuts its work by the number of
/// tasks it is given, so a fixed number makes every result bit-identical on any pool (a
/// number taken from the pool, `Par::rayon(0)`, would not).
pub fn par() -> Par {
    Par::rayon(TASKS)
}

/// What makes floating-point results differ between machines: the architecture and the
/// vector instruction set that faer, rustfft and the kernels here choose at run time (the
/// tiles of [`tall`] give the same bits on AVX2 and AVX-512, faer's kernels do not). Results
/// are bit-identical between machines with the same tag; the engine puts it in every cache
/// key, so that a cache shared by different machines never mixes their bytes.
pub fn numeric_platform() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    {
        if is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512vl") {
            return "x86_64+avx512";
        }
        if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
            return "x86_64+avx2";
        }
    }
    std::env::consts::ARCH
}

/// Makes faer's operators (`&A * &B` and the like, which take faer's global setting) cut
/// their work into [`TASKS`] as well. Whoever runs stages calls it once, first.
pub fn fix_global_parallelism() {
    faer::set_global_parallelism(par());
}

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

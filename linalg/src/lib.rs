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

pub mod block_inverse;
pub mod cholesky;
pub mod csc;
pub mod dense;
pub mod eigensolver;
pub mod gram_schmidt;
pub mod kernels;
pub mod lanczos;
pub mod lblt;
pub mod ldlt;
pub mod lu;
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

/// Defines a function whose body is compiled three times, for AVX-512, for AVX2 and for the
/// baseline, and run in the widest the processor has: loops of independent rows (`w += W δ`,
/// row-by-row products) then use two or four times the baseline's vector lanes. The body's
/// arithmetic is not reordered and no multiply-add is fused (only `avx2` and `avx512f` are
/// enabled, not `fma`), so every version gives the same bits.
///
/// ```
/// squeal_linalg::widest_vectors! {
///     /// `y += a x`.
///     pub fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
///         for (y, x) in y.iter_mut().zip(x) {
///             *y += a * x;
///         }
///     }
/// }
/// let mut y = vec![1.0; 5];
/// axpy(2.0, &[1.0; 5], &mut y);
/// assert_eq!(y, vec![3.0; 5]);
/// ```
#[macro_export]
macro_rules! widest_vectors {
    ($(#[$meta:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[inline(always)]
            fn body($($arg: $ty),*) $(-> $ret)? $body
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2,avx512f")]
                fn avx512($($arg: $ty),*) $(-> $ret)? {
                    body($($arg),*)
                }
                #[target_feature(enable = "avx2")]
                fn avx2($($arg: $ty),*) $(-> $ret)? {
                    body($($arg),*)
                }
                if ::std::is_x86_feature_detected!("avx512f") {
                    // SAFETY: the processor has AVX-512 F.
                    return unsafe { avx512($($arg),*) };
                }
                if ::std::is_x86_feature_detected!("avx2") {
                    // SAFETY: the processor has AVX2.
                    return unsafe { avx2($($arg),*) };
                }
            }
            body($($arg),*)
        }
    };
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

#[cfg(test)]
mod tests {
    /// `w += c₀ δ₀ + c₁ δ₁ + c₂ δ₂`, the contact solvers' update, as the baseline compiles it.
    fn three_columns_baseline(w: &mut [f64], columns: [&[f64]; 3], delta: [f64; 3]) {
        for (row, slot) in w.iter_mut().enumerate() {
            *slot += columns[0][row] * delta[0]
                + columns[1][row] * delta[1]
                + columns[2][row] * delta[2];
        }
    }

    crate::widest_vectors! {
        fn three_columns(w: &mut [f64], columns: [&[f64]; 3], delta: [f64; 3]) {
            for (row, slot) in w.iter_mut().enumerate() {
                *slot += columns[0][row] * delta[0]
                    + columns[1][row] * delta[1]
                    + columns[2][row] * delta[2];
            }
        }
    }

    /// The widest version this processor runs gives the baseline's bits (values spread over
    /// twenty decades, so that any fused multiply-add or reordering would show).
    #[test]
    fn the_widest_vectors_give_the_baseline_bits() {
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let unit = (state >> 11) as f64 / (1u64 << 53) as f64;
            (unit - 0.5) * 10f64.powf(20.0 * unit - 10.0)
        };
        let n = 1003;
        let columns: Vec<Vec<f64>> = (0..3).map(|_| (0..n).map(|_| next()).collect()).collect();
        let start: Vec<f64> = (0..n).map(|_| next()).collect();
        let delta = [next(), next(), next()];
        let columns = [&columns[0][..], &columns[1][..], &columns[2][..]];
        let (mut wide, mut baseline) = (start.clone(), start);
        three_columns(&mut wide, columns, delta);
        three_columns_baseline(&mut baseline, columns, delta);
        assert!(
            wide.iter()
                .zip(&baseline)
                .all(|(a, b)| a.to_bits() == b.to_bits())
        );
    }
}

//! `H = Qᴴ W` for a tall complex `Q` (the Krylov basis: tens of thousands of rows, up to a
//! thousand columns) and a few columns `W` (a Krylov block, 8 or 16): the projections of
//! [`super::krylov`]'s Gram–Schmidt.
//!
//! A general matrix product packs `Qᴴ` into panels before multiplying; with so few columns on
//! the other side, that copy of `Q` costs about as much as the arithmetic, and faer reaches
//! 9–10 GFLOP/s per thread on these shapes. This kernel reads `Q` in place, once: rows are
//! taken in chunks whose part of `W` stays in the second-level cache, and within a chunk two
//! columns of `Q` meet two of `W` at a time, each complex product split into two real FMAs
//! (the `re·re, im·im` and `re·im, im·re` lanes, combined once per chunk). On 28 k rows it
//! reaches 14–16 GFLOP/s per thread on this processor (about 1.5× faer, `cargo bench -p
//! squeal-stages --bench tall`). AVX2 and FMA are chosen at run time; elsewhere, and for views
//! whose rows are not contiguous, faer's product is used. The other products of the
//! Gram–Schmidt, `Q C`, stay with faer, which does as well on them (11–13 GFLOP/s per thread
//! against 10–11 for the same approach).

use faer::linalg::matmul::matmul;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::{Accum, Mat, MatMut, MatRef, Par, c64};
use rayon::prelude::*;

/// Rows per chunk: a chunk of a block of eight columns fills 256 KiB, half the second-level
/// cache (2048 rows: 1.3× faster than 128, which keeps it in the first level).
fn chunk_rows(width: usize) -> usize {
    ((256 << 10) / (16 * width.max(1))).clamp(128, 4096)
}

/// `Qᴴ W`, the rows shared among the threads of `par`.
pub fn adjoint_times(Q: MatRef<'_, c64>, W: MatRef<'_, c64>, par: Par) -> Mat<c64> {
    let (rows, depth, width) = (Q.nrows(), Q.ncols(), W.ncols());
    assert_eq!(rows, W.nrows());
    parts(rows, width, par)
        .into_par_iter()
        .map(|(start, len)| {
            let mut partial = Mat::<c64>::zeros(depth, width);
            add_adjoint_times(
                partial.as_mut(),
                Q.subrows(start, len),
                W.subrows(start, len),
            );
            partial
        })
        .reduce(|| Mat::<c64>::zeros(depth, width), |a, b| a + b)
}

/// Contiguous row ranges, whole chunks each, one per thread of `par`.
fn parts(rows: usize, width: usize, par: Par) -> Vec<(usize, usize)> {
    let threads = match par {
        Par::Seq => 1,
        Par::Rayon(threads) => threads.get(),
    };
    let chunk = chunk_rows(width);
    let chunks = rows.div_ceil(chunk).max(1);
    let per_part = chunks.div_ceil(threads.min(chunks)) * chunk;
    (0..rows)
        .step_by(per_part.max(1))
        .map(|start| (start, per_part.min(rows - start)))
        .collect()
}

/// Whether the kernels apply on this processor to operands with these (row, column) strides:
/// unit row strides and non-negative column strides, as `Mat` and its column views have.
fn kernels_apply(strides: [(isize, isize); 3]) -> bool {
    let contiguous = strides.iter().all(|&(rows, cols)| rows == 1 && cols >= 0);
    #[cfg(target_arch = "x86_64")]
    if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
        return contiguous;
    }
    let _ = contiguous;
    false
}

fn strides(A: MatRef<'_, c64>) -> (isize, isize) {
    (A.row_stride(), A.col_stride())
}

/// `H += Qᴴ W` on the calling thread.
pub fn add_adjoint_times(mut H: MatMut<'_, c64>, Q: MatRef<'_, c64>, W: MatRef<'_, c64>) {
    let (rows, depth, width) = (Q.nrows(), Q.ncols(), W.ncols());
    assert_eq!((H.nrows(), H.ncols(), W.nrows()), (depth, width, rows));
    if rows == 0 || depth == 0 || width == 0 {
        return;
    }
    if !kernels_apply([strides(Q), strides(W), strides(H.rb())]) {
        matmul(H, Accum::Add, Q.adjoint(), W, c64::new(1.0, 0.0), Par::Seq);
        return;
    }
    #[cfg(target_arch = "x86_64")]
    for start in (0..rows).step_by(chunk_rows(width)) {
        let len = chunk_rows(width).min(rows - start);
        let (q, w) = (Q.subrows(start, len), W.subrows(start, len));
        // SAFETY: AVX2 and FMA were detected; every view has unit row stride and the indices
        // stay within their shapes.
        unsafe { avx::add_adjoint_times(H.rb_mut(), q, w) };
    }
}

#[cfg(target_arch = "x86_64")]
mod avx {
    //! The kernels on one chunk of rows. A complex `a + ib` is two adjacent f64; a 256-bit
    //! register holds two complex entries of a column.
    use std::arch::x86_64::*;

    use faer::{MatMut, MatRef, c64};

    /// The f64 address of entry (i, j) of a column-major complex matrix.
    #[inline(always)]
    fn at(base: *const c64, col_stride: isize, i: usize, j: usize) -> *const f64 {
        base.wrapping_offset(i as isize + j as isize * col_stride) as *const f64
    }

    /// `H += Qᴴ W` over the chunk's rows, two columns of Q against two of W at a time.
    ///
    /// # Safety
    /// AVX2 and FMA; unit row strides, non-negative column strides, matching shapes.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn add_adjoint_times(
        mut H: MatMut<'_, c64>,
        Q: MatRef<'_, c64>,
        W: MatRef<'_, c64>,
    ) {
        let (depth, width) = (Q.ncols(), W.ncols());
        let mut k = 0;
        while k < depth {
            let kt = (depth - k).min(2);
            let mut j = 0;
            while j < width {
                let jt = (width - j).min(2);
                let sums = match (kt, jt) {
                    (2, 2) => unsafe { adjoint_tile::<2, 2>(Q, W, k, j) },
                    (2, _) => unsafe { adjoint_tile::<2, 1>(Q, W, k, j) },
                    (_, 2) => unsafe { adjoint_tile::<1, 2>(Q, W, k, j) },
                    _ => unsafe { adjoint_tile::<1, 1>(Q, W, k, j) },
                };
                for a in 0..kt {
                    for b in 0..jt {
                        H[(k + a, j + b)] += sums[a][b];
                    }
                }
                j += jt;
            }
            k += kt;
        }
    }

    /// `Σ_i conj(Q[i, k + a]) W[i, j + b]` for a < K, b < J.
    #[target_feature(enable = "avx2,fma")]
    unsafe fn adjoint_tile<const K: usize, const J: usize>(
        Q: MatRef<'_, c64>,
        W: MatRef<'_, c64>,
        k: usize,
        j: usize,
    ) -> [[c64; 2]; 2] {
        let rows = Q.nrows();
        let (q, qs) = (Q.as_ptr(), Q.col_stride());
        let (w, ws) = (W.as_ptr(), W.col_stride());
        // same[a][b] gathers (re q · re w, im q · im w), cross[a][b] (re q · im w, im q · re w).
        let mut same = [[_mm256_setzero_pd(); J]; K];
        let mut cross = [[_mm256_setzero_pd(); J]; K];
        let pairs = rows / 2;
        for p in 0..pairs {
            let i = 2 * p;
            let mut qv = [_mm256_setzero_pd(); K];
            for a in 0..K {
                qv[a] = unsafe { _mm256_loadu_pd(at(q, qs, i, k + a)) };
            }
            for b in 0..J {
                let wv = unsafe { _mm256_loadu_pd(at(w, ws, i, j + b)) };
                let swapped = _mm256_permute_pd::<0b0101>(wv);
                for a in 0..K {
                    same[a][b] = _mm256_fmadd_pd(qv[a], wv, same[a][b]);
                    cross[a][b] = _mm256_fmadd_pd(qv[a], swapped, cross[a][b]);
                }
            }
        }
        let mut sums = [[c64::new(0.0, 0.0); 2]; 2];
        // re = Σ same lanes; im = Σ (re q · im w − im q · re w) = cross lanes 0 − 1 + 2 − 3.
        let sign = _mm256_setr_pd(1.0, -1.0, 1.0, -1.0);
        for a in 0..K {
            for b in 0..J {
                let paired = _mm256_hadd_pd(same[a][b], _mm256_mul_pd(cross[a][b], sign));
                let folded = _mm_add_pd(
                    _mm256_castpd256_pd128(paired),
                    _mm256_extractf128_pd::<1>(paired),
                );
                let mut out = [0.0f64; 2];
                unsafe { _mm_storeu_pd(out.as_mut_ptr(), folded) };
                sums[a][b] = c64::new(out[0], out[1]);
            }
        }
        if rows % 2 == 1 {
            let i = rows - 1;
            for a in 0..K {
                for b in 0..J {
                    sums[a][b] += Q[(i, k + a)].conj() * W[(i, j + b)];
                }
            }
        }
        sums
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::modes::lanczos::SplitMix64;

    fn random(rows: usize, cols: usize, random: &mut SplitMix64) -> Mat<c64> {
        Mat::from_fn(rows, cols, |_, _| {
            c64::new(random.next_signed(), random.next_signed())
        })
    }

    fn largest_difference(a: MatRef<'_, c64>, b: MatRef<'_, c64>) -> f64 {
        let mut worst = 0.0f64;
        for j in 0..a.ncols() {
            for i in 0..a.nrows() {
                worst = worst.max((a[(i, j)] - b[(i, j)]).norm());
            }
        }
        worst
    }

    /// Every tile shape and remainder (odd rows, depths and widths around the tile size of
    /// two, several chunks, views with padded column strides), on one and two threads, against
    /// faer's product: entries of order one summed over at most 4,099 rows, so 1e-11 is
    /// round-off.
    #[test]
    fn the_tall_product_equals_faers() {
        let mut rng = SplitMix64::new(7);
        for &rows in &[1usize, 2, 5, 131, 4099] {
            for &depth in &[1usize, 2, 3, 4, 5, 9] {
                for &width in &[1usize, 2, 3, 8, 16] {
                    // Views into larger matrices, so that column strides exceed the rows.
                    let big_q = random(rows + 3, depth + 1, &mut rng);
                    let Q = big_q.submatrix(1, 1, rows, depth);
                    let W = random(rows, width, &mut rng);
                    let reference = Q.adjoint() * &W;
                    for par in [Par::Seq, Par::rayon(2)] {
                        let h = adjoint_times(Q, W.as_ref(), par);
                        assert!(
                            largest_difference(h.as_ref(), reference.as_ref()) < 1e-11,
                            "Qᴴ W, {rows} × {depth} against {width}, {par:?}"
                        );
                    }
                }
            }
        }
    }
}

//! Products of a tall complex `Q` (the Krylov basis: tens of thousands of rows, up to a
//! thousand columns) with a few columns (a Krylov block, 8 or 16):
//!
//! ```text
//! H = Qᴴ W      the projections of Gram–Schmidt
//! X += Q C     its updates, the block rebuilt from its coordinates, the contact correction
//! ```
//!
//! A general matrix product packs `Q` into panels before multiplying; with so few columns on
//! the other side, that copy of `Q` costs about as much as the arithmetic. These kernels read
//! `Q` in place, once, each
//! complex product split into two real FMAs (`q · re c` and `q · im c`, or the `re·re, im·im`
//! and `re·im, im·re` lanes), combined once per tile rather than per product:
//!
//! - `Qᴴ W`: rows in chunks whose part of `W` stays in the second-level cache; within a
//!   chunk two columns of `Q` (four with AVX-512) meet two of `W` at a time, summed down the
//!   rows.
//! - `Q C`: for 128 rows and a block of 128 columns of `Q`, four rows and two columns of `C`
//!   (four with AVX-512) at a time are summed across the block in registers. Four rows of `Q`
//!   are one cache line per column, the lines a column apart, which the processor does not
//!   prefetch: the first pass over a block prefetches the rows two steps ahead.
//!
//! The wider tiles need 16 accumulators, which only the 32 vector registers of AVX-512 hold
//! (the vectors stay 256 bits wide); they read each operand from the second-level cache half
//! as often, which is what bounds the narrow tiles. Both sum every entry in the same order:
//! their results are bit-identical. AVX2 and FMA, and AVX-512, are chosen at run time;
//! elsewhere, for views whose rows are not contiguous, and for `C` wider than 32 columns,
//! faer's product is used. Timings: `docs/PERFORMANCE.md`.

use faer::linalg::matmul::matmul;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::{Accum, Mat, MatMut, MatRef, Par, c64};
use rayon::prelude::*;

/// Rows per chunk: a chunk of a block of eight columns fills 256 KiB, half the second-level
/// cache.
fn chunk_rows(width: usize) -> usize {
    ((256 << 10) / (16 * width.max(1))).clamp(128, 4096)
}

/// `Qᴴ W`: the partial products of fixed row chunks, on the threads of `par`, added in
/// chunk order.
pub fn adjoint_times(Q: MatRef<'_, c64>, W: MatRef<'_, c64>, par: Par) -> Mat<c64> {
    let (rows, depth, width) = (Q.nrows(), Q.ncols(), W.ncols());
    assert_eq!(rows, W.nrows());
    let partial = |(start, len): (usize, usize)| {
        let mut partial = Mat::<c64>::zeros(depth, width);
        add_adjoint_times(
            partial.as_mut(),
            Q.subrows(start, len),
            W.subrows(start, len),
        );
        partial
    };
    sum_in_order(in_parts(parts(rows, width), par, partial), depth, width)
}

/// Contiguous ranges of [`chunk_rows`] rows. They depend on the shape only, never on the
/// number of threads, so that every sum over rows is made in the same order whatever the
/// pool: results are bit-identical on any thread count (the engine caches by content).
fn parts(rows: usize, width: usize) -> Vec<(usize, usize)> {
    let chunk = chunk_rows(width);
    (0..rows)
        .step_by(chunk)
        .map(|start| (start, chunk.min(rows - start)))
        .collect()
}

/// `f` of every part, in order, on the threads of `par`.
fn in_parts<T: Send, P: Send>(parts: Vec<P>, par: Par, f: impl Fn(P) -> T + Sync + Send) -> Vec<T> {
    match par {
        Par::Seq => parts.into_iter().map(f).collect(),
        Par::Rayon(_) => parts.into_par_iter().map(f).collect(),
    }
}

/// The sum of `partials`, added in their order.
fn sum_in_order(partials: Vec<Mat<c64>>, depth: usize, width: usize) -> Mat<c64> {
    let mut total = Mat::<c64>::zeros(depth, width);
    for partial in &partials {
        total += partial;
    }
    total
}

/// `X` cut into the row ranges of [`parts`], each with its first row.
fn row_pieces(X: MatMut<'_, c64>, width: usize) -> Vec<(usize, MatMut<'_, c64>)> {
    let mut pieces = Vec::new();
    let mut rest = X;
    for (start, len) in parts(rest.nrows(), width) {
        let (head, tail) = rest.split_at_row_mut(len);
        pieces.push((start, head));
        rest = tail;
    }
    pieces
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

/// Whether the processor has AVX-512 (F and VL): its 32 vector registers hold the wider
/// tiles.
#[cfg(target_arch = "x86_64")]
fn wide_tiles() -> bool {
    is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512vl")
}

fn strides(A: MatRef<'_, c64>) -> (isize, isize) {
    (A.row_stride(), A.col_stride())
}

/// `H += Qᴴ W` on the calling thread.
fn add_adjoint_times(mut H: MatMut<'_, c64>, Q: MatRef<'_, c64>, W: MatRef<'_, c64>) {
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
    let wide = wide_tiles();
    #[cfg(target_arch = "x86_64")]
    for start in (0..rows).step_by(chunk_rows(width)) {
        let len = chunk_rows(width).min(rows - start);
        let (q, w) = (Q.subrows(start, len), W.subrows(start, len));
        // SAFETY: AVX2 and FMA were detected; every view has unit row stride and the indices
        // stay within their shapes.
        unsafe {
            if wide {
                avx::add_adjoint_times_wide(H.rb_mut(), q, w)
            } else {
                avx::add_adjoint_times(H.rb_mut(), q, w)
            }
        };
    }
}

/// `X += Q C`, fixed row chunks on the threads of `par`. Wider `C` (eigenvectors by the
/// hundred) go to faer's sequential product per chunk, whose packed copy of `Q` then serves
/// many columns.
pub fn add_times(X: MatMut<'_, c64>, Q: MatRef<'_, c64>, C: MatRef<'_, c64>, par: Par) {
    assert_eq!(X.nrows(), Q.nrows());
    let update = |(start, piece): (usize, MatMut<'_, c64>)| {
        let len = piece.nrows();
        if C.ncols() > MAX_KERNEL_WIDTH {
            matmul(
                piece,
                Accum::Add,
                Q.subrows(start, len),
                C,
                c64::new(1.0, 0.0),
                Par::Seq,
            );
        } else {
            add_times_one_thread(piece, Q.subrows(start, len), C)
        }
    };
    in_parts(row_pieces(X, C.ncols()), par, update);
}

/// `Z −= Q C`, then `Qᴴ Z` of the result: a Gram–Schmidt update and the next pass's
/// projection in one sweep over `Q` from memory. Each strip of `STRIP_ROWS` rows is updated,
/// then projected while its part of `Q` is still in cache. The products with blocks of eight
/// are bound by memory traffic, so the second read, from cache, costs less than a sweep.
pub fn subtract_then_adjoint_times(
    Z: MatMut<'_, c64>,
    Q: MatRef<'_, c64>,
    C: MatRef<'_, c64>,
    par: Par,
) -> Mat<c64> {
    let (rows, depth, width) = (Q.nrows(), Q.ncols(), Z.ncols());
    assert_eq!((Z.nrows(), C.nrows(), C.ncols()), (rows, depth, width));
    let negated = -C;
    let update_then_project = |(start, mut piece): (usize, MatMut<'_, c64>)| {
        let mut partial = Mat::<c64>::zeros(depth, width);
        let len = piece.nrows();
        for first in (0..len).step_by(STRIP_ROWS) {
            let strip = STRIP_ROWS.min(len - first);
            let q = Q.subrows(start + first, strip);
            let mut z = piece.rb_mut().subrows_mut(first, strip);
            add_times_one_thread(z.rb_mut(), q, negated.as_ref());
            add_adjoint_times(partial.as_mut(), q, z.rb());
        }
        partial
    };
    sum_in_order(
        in_parts(row_pieces(Z, width), par, update_then_project),
        depth,
        width,
    )
}

/// Rows per strip of [`subtract_then_adjoint_times`]: 128 rows of a thousand columns (2 MiB
/// per thread) stay in the third-level cache between the two products.
const STRIP_ROWS: usize = 128;

/// `X += Q C` on the calling thread.
fn add_times_one_thread(mut X: MatMut<'_, c64>, Q: MatRef<'_, c64>, C: MatRef<'_, c64>) {
    let (rows, depth, width) = (Q.nrows(), Q.ncols(), C.ncols());
    assert_eq!((X.nrows(), X.ncols(), C.nrows()), (rows, width, depth));
    if rows == 0 || depth == 0 || width == 0 {
        return;
    }
    if !kernels_apply([strides(Q), strides(X.rb()), strides(C)]) {
        matmul(X, Accum::Add, Q, C, c64::new(1.0, 0.0), Par::Seq);
        return;
    }
    #[cfg(target_arch = "x86_64")]
    let wide = wide_tiles();
    #[cfg(target_arch = "x86_64")]
    for start in (0..rows).step_by(TIMES_CHUNK_ROWS) {
        let len = TIMES_CHUNK_ROWS.min(rows - start);
        // SAFETY: as in `add_adjoint_times`.
        let (x, q) = (X.rb_mut().subrows_mut(start, len), Q.subrows(start, len));
        unsafe {
            if wide {
                avx::add_times_wide(x, q, C)
            } else {
                avx::add_times(x, q, C)
            }
        };
    }
}

/// Widest `C` for the kernel of `Q C`.
const MAX_KERNEL_WIDTH: usize = 32;

/// Rows per chunk of `Q C`: a chunk's 128 columns of a k-block (256 KiB) stay in the
/// second-level cache while every pair of columns of C passes over them.
const TIMES_CHUNK_ROWS: usize = 128;

#[cfg(target_arch = "x86_64")]
mod avx {
    //! The kernels on one chunk of rows. A complex `a + ib` is two adjacent f64; a 256-bit
    //! register holds two complex entries of a column.
    use std::arch::x86_64::*;

    use faer::reborrow::ReborrowMut;

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
    pub unsafe fn add_adjoint_times(H: MatMut<'_, c64>, Q: MatRef<'_, c64>, W: MatRef<'_, c64>) {
        unsafe { adjoint_times_tiled::<2>(H, Q, W) }
    }

    /// The same, four columns of Q against two of W at a time: the 16 accumulators and the
    /// operands need the 32 vector registers of AVX-512 (on 256-bit vectors).
    ///
    /// # Safety
    /// AVX-512F and VL, AVX2 and FMA; as [`add_adjoint_times`].
    #[target_feature(enable = "avx2,fma,avx512f,avx512vl")]
    pub unsafe fn add_adjoint_times_wide(
        H: MatMut<'_, c64>,
        Q: MatRef<'_, c64>,
        W: MatRef<'_, c64>,
    ) {
        unsafe { adjoint_times_tiled::<4>(H, Q, W) }
    }

    #[inline(always)]
    unsafe fn adjoint_times_tiled<const TILE: usize>(
        mut H: MatMut<'_, c64>,
        Q: MatRef<'_, c64>,
        W: MatRef<'_, c64>,
    ) {
        let (depth, width) = (Q.ncols(), W.ncols());
        let mut k = 0;
        while k < depth {
            let kt = (depth - k).min(TILE);
            let mut j = 0;
            while j < width {
                let jt = (width - j).min(2);
                let sums = match (kt, jt) {
                    (4, 2) => unsafe { adjoint_tile::<4, 2>(Q, W, k, j) },
                    (4, _) => unsafe { adjoint_tile::<4, 1>(Q, W, k, j) },
                    (3, 2) => unsafe { adjoint_tile::<3, 2>(Q, W, k, j) },
                    (3, _) => unsafe { adjoint_tile::<3, 1>(Q, W, k, j) },
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
    #[inline(always)]
    unsafe fn adjoint_tile<const K: usize, const J: usize>(
        Q: MatRef<'_, c64>,
        W: MatRef<'_, c64>,
        k: usize,
        j: usize,
    ) -> [[c64; 2]; 4] {
        // SAFETY: the callers enable AVX2 and FMA; indices as in `add_adjoint_times`.
        unsafe {
            let rows = Q.nrows();
            let (q, qs) = (Q.as_ptr(), Q.col_stride());
            let (w, ws) = (W.as_ptr(), W.col_stride());
            // same[a][b] gathers (re q · re w, im q · im w), cross[a][b] (re q · im w, im q · re w).
            let mut same = [[_mm256_setzero_pd(); J]; K];
            let mut cross = [[_mm256_setzero_pd(); J]; K];
            let pairs = rows / 2;
            for p in 0..pairs {
                let i = 2 * p;
                let qv: [__m256d; K] =
                    std::array::from_fn(|a| _mm256_loadu_pd(at(q, qs, i, k + a)));
                for b in 0..J {
                    let wv = _mm256_loadu_pd(at(w, ws, i, j + b));
                    let swapped = _mm256_permute_pd::<0b0101>(wv);
                    for a in 0..K {
                        same[a][b] = _mm256_fmadd_pd(qv[a], wv, same[a][b]);
                        cross[a][b] = _mm256_fmadd_pd(qv[a], swapped, cross[a][b]);
                    }
                }
            }
            let mut sums = [[c64::new(0.0, 0.0); 2]; 4];
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
                    _mm_storeu_pd(out.as_mut_ptr(), folded);
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
    /// Columns of Q per k-block of `Q C`.
    const K_BLOCK: usize = 128;

    /// `X += Q C` over the chunk's rows: for each k-block, each pair of columns of C, each
    /// four rows, the block's columns of Q are summed in registers.
    ///
    /// # Safety
    /// As [`add_adjoint_times`].
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn add_times(X: MatMut<'_, c64>, Q: MatRef<'_, c64>, C: MatRef<'_, c64>) {
        unsafe { times_tiled::<2>(X, Q, C) }
    }

    /// The same, four columns of C at a time (16 accumulators: the registers of AVX-512),
    /// which halves the passes over each k-block of Q.
    ///
    /// # Safety
    /// As [`add_adjoint_times_wide`].
    #[target_feature(enable = "avx2,fma,avx512f,avx512vl")]
    pub unsafe fn add_times_wide(X: MatMut<'_, c64>, Q: MatRef<'_, c64>, C: MatRef<'_, c64>) {
        unsafe { times_tiled::<4>(X, Q, C) }
    }

    #[inline(always)]
    unsafe fn times_tiled<const TILE: usize>(
        mut X: MatMut<'_, c64>,
        Q: MatRef<'_, c64>,
        C: MatRef<'_, c64>,
    ) {
        let (depth, width) = (Q.ncols(), C.ncols());
        for k in (0..depth).step_by(K_BLOCK) {
            let block = K_BLOCK.min(depth - k);
            let mut j = 0;
            while j < width {
                let first_pass = j == 0;
                let jt = (width - j).min(TILE);
                let (X, j0) = (X.rb_mut(), j);
                unsafe {
                    match jt {
                        4 => times_tile::<4>(X, Q, C, k, block, j0, first_pass),
                        3 => times_tile::<3>(X, Q, C, k, block, j0, first_pass),
                        2 => times_tile::<2>(X, Q, C, k, block, j0, first_pass),
                        _ => times_tile::<1>(X, Q, C, k, block, j0, first_pass),
                    }
                };
                j += jt;
            }
        }
    }

    /// `X[:, j..j + J] += Q[:, k..k + block] C[k..k + block, j..j + J]`. The first pass over
    /// a k-block prefetches the rows four ahead, which the processor would not (one line per
    /// column, a hundred columns apart).
    #[inline(always)]
    unsafe fn times_tile<const J: usize>(
        mut X: MatMut<'_, c64>,
        Q: MatRef<'_, c64>,
        C: MatRef<'_, c64>,
        k: usize,
        block: usize,
        j: usize,
        prefetch: bool,
    ) {
        // SAFETY: the callers enable AVX2 and FMA; indices as in `add_times`.
        unsafe {
            let rows = X.nrows();
            let (q, qs) = (Q.as_ptr(), Q.col_stride());
            let (c, cs) = (C.as_ptr(), C.col_stride());
            let (x, xs) = (X.as_ptr_mut(), X.col_stride());
            let quads = rows / 4;
            for t in 0..quads {
                let i = 4 * t;
                // real = q · re c, imag = q · im c, for rows i, i + 1 and i + 2, i + 3.
                let mut real = [[_mm256_setzero_pd(); J]; 2];
                let mut imag = [[_mm256_setzero_pd(); J]; 2];
                for a in k..k + block {
                    if prefetch {
                        _mm_prefetch::<_MM_HINT_T0>(at(q, qs, i + 8, a) as *const i8);
                    }
                    let low = _mm256_loadu_pd(at(q, qs, i, a));
                    let high = _mm256_loadu_pd(at(q, qs, i + 2, a));
                    for b in 0..J {
                        let entry = at(c, cs, a, j + b);
                        let re = _mm256_broadcast_sd(&*entry);
                        let im = _mm256_broadcast_sd(&*entry.add(1));
                        real[0][b] = _mm256_fmadd_pd(low, re, real[0][b]);
                        imag[0][b] = _mm256_fmadd_pd(low, im, imag[0][b]);
                        real[1][b] = _mm256_fmadd_pd(high, re, real[1][b]);
                        imag[1][b] = _mm256_fmadd_pd(high, im, imag[1][b]);
                    }
                }
                // q c = real + (−im, re) of imag.
                for half in 0..2 {
                    for b in 0..J {
                        let target = at(x, xs, i + 2 * half, j + b) as *mut f64;
                        let product = _mm256_addsub_pd(
                            real[half][b],
                            _mm256_permute_pd::<0b0101>(imag[half][b]),
                        );
                        _mm256_storeu_pd(target, _mm256_add_pd(_mm256_loadu_pd(target), product));
                    }
                }
            }
            for i in 4 * quads..rows {
                for b in 0..J {
                    let mut sum = c64::new(0.0, 0.0);
                    for a in k..k + block {
                        sum += Q[(i, a)] * C[(a, j + b)];
                    }
                    X[(i, j + b)] += sum;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests;

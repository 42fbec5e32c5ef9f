//! Tall-skinny dense products (`n` rows, tens to hundreds of columns), parallel over fixed
//! chunks of rows with each chunk a sequential faer kernel.
//!
//! The chunks do not depend on the number of threads and partial sums are added in chunk
//! order, so results are bit-identical whatever the pool size (the engine caches by content
//! hash). faer's own parallel kernels are slower on these shapes (a reduction over the long
//! dimension), and their results depend on the thread count.

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatMut, MatRef, Par};
use rayon::prelude::*;

/// Rows per task.
const ROWS_PER_CHUNK: usize = 4096;

/// `Qᵀ W`.
pub fn transpose_times(Q: MatRef<'_, f64>, W: MatRef<'_, f64>) -> Mat<f64> {
    let partials: Vec<Mat<f64>> = Q
        .par_row_chunks(ROWS_PER_CHUNK)
        .zip(W.par_row_chunks(ROWS_PER_CHUNK))
        .map(|(Q_chunk, W_chunk)| {
            let mut partial = Mat::<f64>::zeros(Q.ncols(), W.ncols());
            matmul(
                partial.as_mut(),
                Accum::Replace,
                Q_chunk.transpose(),
                W_chunk,
                1.0,
                Par::Seq,
            );
            partial
        })
        .collect();
    let mut total = Mat::<f64>::zeros(Q.ncols(), W.ncols());
    for partial in &partials {
        total += partial;
    }
    total
}

/// `W ← W + α Q H`.
pub fn add_product(W: MatMut<'_, f64>, Q: MatRef<'_, f64>, H: MatRef<'_, f64>, alpha: f64) {
    W.par_row_chunks_mut(ROWS_PER_CHUNK)
        .zip(Q.par_row_chunks(ROWS_PER_CHUNK))
        .for_each(|(W_chunk, Q_chunk)| {
            matmul(W_chunk, Accum::Add, Q_chunk, H, alpha, Par::Seq);
        });
}

/// `Q H`.
pub fn times(Q: MatRef<'_, f64>, H: MatRef<'_, f64>) -> Mat<f64> {
    let mut product = Mat::<f64>::zeros(Q.nrows(), H.ncols());
    add_product(product.as_mut(), Q, H, 1.0);
    product
}

//! Vector kernels on slices, compiled for the widest vector unit the processor has
//! ([`crate::widest_vectors!`]), with a fixed order of operations: the same bits on every
//! processor and thread count.

/// Partial sums of a dot product: independent chains the vector unit can carry.
pub const LANES: usize = 8;

/// The chains' partial sums added by a fixed tree.
#[inline(always)]
fn sum_lanes([l0, l1, l2, l3, l4, l5, l6, l7]: [f64; LANES]) -> f64 {
    ((l0 + l1) + (l2 + l3)) + ((l4 + l5) + (l6 + l7))
}

crate::widest_vectors! {
    /// `Σ a_k b_k` in [`LANES`] chains, summed by a fixed tree.
    pub fn dot(a: &[f64], b: &[f64]) -> f64 {
        let mut lanes = [0.0; LANES];
        let whole = a.len() - a.len() % LANES;
        for (a, b) in a[..whole].chunks_exact(LANES).zip(b[..whole].chunks_exact(LANES)) {
            for lane in 0..LANES {
                lanes[lane] += a[lane] * b[lane];
            }
        }
        for (lane, k) in (whole..a.len()).enumerate() {
            lanes[lane] += a[k] * b[k];
        }
        sum_lanes(lanes)
    }
}

crate::widest_vectors! {
    /// `Σ a_k b_k` as [`dot`] computes it, and `y += alpha a`, in one pass over `a`: a
    /// symmetric matrix's column of its lower triangle serves its row and its column at once.
    pub fn dot_and_axpy(a: &[f64], b: &[f64], alpha: f64, y: &mut [f64]) -> f64 {
        let mut lanes = [0.0; LANES];
        let whole = a.len() - a.len() % LANES;
        let chunks = a[..whole]
            .chunks_exact(LANES)
            .zip(b[..whole].chunks_exact(LANES))
            .zip(y[..whole].chunks_exact_mut(LANES));
        for ((a, b), y) in chunks {
            for lane in 0..LANES {
                lanes[lane] += a[lane] * b[lane];
                y[lane] += alpha * a[lane];
            }
        }
        for (lane, k) in (whole..a.len()).enumerate() {
            lanes[lane] += a[k] * b[k];
            y[k] += alpha * a[k];
        }
        sum_lanes(lanes)
    }
}

crate::widest_vectors! {
    /// `y += a x`.
    pub fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
        for (y, x) in y.iter_mut().zip(x) {
            *y += a * x;
        }
    }
}

crate::widest_vectors! {
    /// `y += a x` for `x` stored in single precision, widened to double.
    pub fn axpy_single(a: f64, x: &[f32], y: &mut [f64]) {
        for (y, x) in y.iter_mut().zip(x) {
            *y += a * f64::from(*x);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every length around the lanes: the chains and the tail agree with a plain sum, and
    /// `axpy` with its definition; the fused kernel with both, and the widening `axpy` with
    /// `axpy` on values single precision holds exactly.
    #[test]
    fn dot_and_axpy_agree_with_their_definitions_at_every_length() {
        for n in 0..3 * LANES + 2 {
            let a: Vec<f64> = (0..n).map(|k| ((k * 7) % 5) as f64 - 1.5).collect();
            let b: Vec<f64> = (0..n).map(|k| 0.25 * k as f64 + 1.0).collect();
            let plain: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
            // Sums of multiples of 1/8 below 2^40: exact in any order.
            assert_eq!(dot(&a, &b), plain, "length {n}");
            let mut y = b.clone();
            axpy(-2.0, &a, &mut y);
            for k in 0..n {
                assert_eq!(y[k], b[k] - 2.0 * a[k]);
            }
            let mut fused = b.clone();
            assert_eq!(dot_and_axpy(&a, &b, -2.0, &mut fused), plain, "length {n}");
            assert_eq!(fused, y);
            let single: Vec<f32> = a.iter().map(|&x| x as f32).collect();
            let mut widened = b.clone();
            axpy_single(-2.0, &single, &mut widened);
            assert_eq!(widened, y, "length {n}");
        }
    }
}

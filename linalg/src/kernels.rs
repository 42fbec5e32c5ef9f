//! Vector kernels on slices, compiled for the widest vector unit the processor has
//! ([`crate::widest_vectors!`]), with a fixed order of operations: the same bits on every
//! processor and thread count.

/// Partial sums of a dot product: independent chains the vector unit can carry.
const LANES: usize = 8;

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
        let [l0, l1, l2, l3, l4, l5, l6, l7] = lanes;
        ((l0 + l1) + (l2 + l3)) + ((l4 + l5) + (l6 + l7))
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Every length around the lanes: the chains and the tail agree with a plain sum, and
    /// `axpy` with its definition.
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
        }
    }
}

//! Deterministic pseudo-random numbers for start and replacement vectors of the Krylov
//! methods: a run's results must not change from run to run, nor with the thread count.

use faer::Mat;

/// Deterministic pseudo-random numbers (SplitMix64) for start and replacement vectors: the
/// results must not change from run to run.
pub struct SplitMix64(u64);

impl SplitMix64 {
    pub fn new(seed: u64) -> Self {
        SplitMix64(seed)
    }

    /// Uniform in [−1, 1).
    pub fn next_signed(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }

    pub fn block(&mut self, n: usize, n_cols: usize) -> Mat<f64> {
        let mut block = Mat::<f64>::zeros(n, n_cols);
        for j in 0..n_cols {
            for i in 0..n {
                block[(i, j)] = self.next_signed();
            }
        }
        block
    }
}

impl SplitMix64 {
    /// A complex block with real and imaginary parts uniform in [−1, 1).
    pub fn complex_block(&mut self, rows: usize, cols: usize) -> Mat<faer::c64> {
        Mat::from_fn(rows, cols, |_, _| {
            faer::c64::new(self.next_signed(), self.next_signed())
        })
    }
}

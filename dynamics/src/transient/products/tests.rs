use super::*;
use squeal_linalg::kernels::LANES;

/// A symmetric tridiagonal matrix with diagonal `d` and off-diagonal `e`.
fn tridiagonal(n: usize, d: impl Fn(usize) -> f64, e: impl Fn(usize) -> f64) -> CscMatrix {
    let mut triplets = Vec::new();
    for i in 0..n {
        triplets.push((i, i, d(i)));
        if i + 1 < n {
            triplets.push((i, i + 1, e(i)));
            triplets.push((i + 1, i, e(i)));
        }
    }
    CscMatrix::from_triplets(n, n, triplets)
}

fn combination(terms: &[(f64, &CscMatrix)]) -> CscMatrix {
    let n = terms[0].1.n_cols;
    let triplets = terms
        .iter()
        .flat_map(|&(factor, A)| A.triplets().map(move |(i, j, v)| (i, j, factor * v)))
        .collect();
    CscMatrix::from_triplets(n, n, triplets)
}

/// Two parts sharing no DOF, each with its own Rayleigh damping: C is found to be
/// `diag(a) M + diag(b) K`, and both kinds of products agree to rounding, with `M x`
/// derived from `J x`.
#[test]
fn rayleigh_damping_per_part_streams_k_alone_and_agrees_with_the_fused_products() {
    let n = 40;
    let M = tridiagonal(
        n,
        |i| 2.0 + 0.01 * i as f64,
        |i| if i == 19 { 0.0 } else { 0.5 },
    );
    let K = tridiagonal(
        n,
        |i| 3e8 + 1e6 * i as f64,
        |i| if i == 19 { 0.0 } else { -1e8 },
    );
    let part = |i: usize| usize::from(i >= 20);
    let (alpha, beta) = ([3.0, 40.0], [2e-6, 5e-8]);
    let triplets = [(&M, alpha), (&K, beta)]
        .into_iter()
        .flat_map(|(A, coefficients)| {
            A.triplets()
                .map(move |(row, col, value)| (row, col, coefficients[part(row)] * value))
        })
        .collect();
    let C = CscMatrix::from_triplets(n, n, triplets);
    let rayleigh = Products::new(&M, &C, &K);
    assert!(rayleigh.is_rayleigh());
    assert!(
        !rayleigh.streams_lower_runs(),
        "a tridiagonal K is read by rows"
    );
    let fused = Products::fused(&C, &K);
    let (tau, theta) = (1e-6, 0.6);
    let J = combination(&[(1.0 / tau, &M), (theta, &C), (tau * theta * theta, &K)]);
    let x: Vec<f64> = (0..n).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
    let J_x = J.mul_vec(&x);
    let (mut by_rayleigh, mut by_fused) = (vec![[0.0; 3]; n], vec![[0.0; 3]; n]);
    rayleigh.of_solution(&x, &J_x, tau, theta, &mut by_rayleigh);
    fused.of_solution(&x, &J_x, tau, theta, &mut by_fused);
    let exact = [M.mul_vec(&x), C.mul_vec(&x), K.mul_vec(&x)];
    for i in 0..n {
        for d in 0..3 {
            let scale = exact[d].iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            for got in [by_rayleigh[i][d], by_fused[i][d]] {
                assert!(
                    (got - exact[d][i]).abs() <= 1e-8 * scale,
                    "row {i}, product {d}: {got} against {}",
                    exact[d][i]
                );
            }
        }
    }
    // Given M x, both give C x and K x.
    let mut given: Vec<[f64; 3]> = exact[0].iter().map(|&m| [m, 0.0, 0.0]).collect();
    rayleigh.with_mass(&x, &mut given);
    for i in 0..n {
        let scale = exact[1].iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        assert!((given[i][1] - exact[1][i]).abs() <= 1e-12 * scale);
        assert_eq!(given[i][2], exact[2][i]);
    }
}

/// A reduced model's pattern, `n = 2 RUN_CHUNK + 77`: dense blocks, two bodies that do not
/// couple, and modal coordinates that couple with both bodies if `modes_couple` (`K` has
/// no blocks between the bodies and the modes, `C` does); a gap in each column, so that
/// runs end and start again within it, longer and shorter than the lanes.
fn dense_blocks(scale: f64, modes_couple: bool) -> CscMatrix {
    let n = 2 * RUN_CHUNK + 77;
    let body = |i: usize| match i {
        _ if i < 200 => Some(0),
        _ if i < 411 => Some(1),
        _ => None,
    };
    let mut triplets = Vec::new();
    for j in 0..n {
        for i in j..n {
            let coupled = match (body(i), body(j)) {
                (Some(a), Some(b)) => a == b,
                (None, None) => true,
                _ => modes_couple,
            };
            if coupled && (i == j || (i + 3 * j) % 41 != 0) {
                let value = if i == j {
                    scale * (n as f64)
                } else {
                    scale * (((i * 7 + j * 13) % 17) as f64 - 8.0) / 9.0
                };
                triplets.push((i, j, value));
                if i != j {
                    triplets.push((j, i, value));
                }
            }
        }
    }
    CscMatrix::from_triplets(n, n, triplets)
}

/// The fused products over a reduced model's lower runs agree with both triangles'
/// products to rounding, and their bits do not depend on the thread count.
#[test]
fn products_over_the_lower_runs_agree_and_keep_their_bits_on_any_thread_count() {
    let n = 2 * RUN_CHUNK + 77;
    let (C, K) = (dense_blocks(3e-4, true), dense_blocks(2e7, false));
    let products = LowerRuns::new([&C, &K]);
    assert!(
        products
            .triangles
            .iter()
            .all(|triangle| triangle.runs.iter().any(|run| run.len > 3 * LANES))
    );
    let x: Vec<f64> = (0..n).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
    let CK_x = products.times(&x);
    assert_products_agree(&CK_x, &[C.mul_vec(&x), K.mul_vec(&x)], 1e-13);
    assert_same_bits_on_any_thread_count(&CK_x, || products.times(&x));
}

/// Each product `got[i][d]` within `tolerance` of `exact[d][i]`, relative to the largest
/// `exact[d]`.
fn assert_products_agree<const N: usize>(got: &[[f64; N]], exact: &[Vec<f64>], tolerance: f64) {
    for (d, exact) in exact.iter().enumerate() {
        let scale = exact.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        for (i, (got, exact)) in got.iter().zip(exact).enumerate() {
            assert!(
                (got[d] - exact).abs() <= tolerance * scale,
                "row {i}, product {d}: {} against {exact}",
                got[d]
            );
        }
    }
}

/// `compute` gives `expected`'s bits on 1 and 3 threads.
fn assert_same_bits_on_any_thread_count<const N: usize>(
    expected: &[[f64; N]],
    compute: impl Fn() -> Vec<[f64; N]> + Send + Sync,
) {
    for threads in [1, 3] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let on_pool = pool.install(&compute);
        assert!(
            on_pool
                .iter()
                .flatten()
                .zip(expected.iter().flatten())
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "the bits changed on {threads} threads"
        );
    }
}

/// A reduced model with the pads kept whole: dense blocks, Rayleigh damping row by row.
/// A step streams `K`'s lower runs alone, and the products agree with the exact ones to
/// rounding, with the same bits on any thread count.
#[test]
fn a_dense_rayleigh_model_streams_k_by_its_lower_runs() {
    let n = 2 * RUN_CHUNK + 77;
    let (M, K) = (dense_blocks(1.0, false), dense_blocks(2e7, false));
    let (alpha, beta) = (3.0, 5e-8);
    let C = combination(&[(alpha, &M), (beta, &K)]);
    let products = Products::new(&M, &C, &K);
    assert!(products.streams_lower_runs());
    let (tau, theta) = (1e-6, 0.5);
    let J = combination(&[(1.0 / tau, &M), (theta, &C), (tau * theta * theta, &K)]);
    let x: Vec<f64> = (0..n).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
    let J_x = J.mul_vec(&x);
    let solution = || {
        let mut out = vec![[0.0; 3]; n];
        products.of_solution(&x, &J_x, tau, theta, &mut out);
        out
    };
    let got = solution();
    assert_products_agree(&got, &[M.mul_vec(&x), C.mul_vec(&x), K.mul_vec(&x)], 1e-8);
    assert_same_bits_on_any_thread_count(&got, solution);
}

/// Damping that is not row-wise Rayleigh (a dashpot between two DOFs of different
/// rows' coefficients) keeps the fused products.
#[test]
fn other_damping_keeps_the_fused_products() {
    let n = 6;
    let M = tridiagonal(n, |_| 1.0, |_| 0.0);
    let K = tridiagonal(n, |_| 2.0, |_| -1.0);
    let C = tridiagonal(
        n,
        |i| if i == 2 { 0.7 } else { 0.1 },
        |i| if i == 2 { -0.4 } else { 0.0 },
    );
    assert!(!Products::new(&M, &C, &K).is_rayleigh());
}

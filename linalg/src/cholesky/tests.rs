use super::*;
use crate::rng::SplitMix64;

/// A random sparse SPD matrix: a 1D Laplacian-like band plus a diagonal shift, on `n`
/// unknowns, and a second term to combine with.
fn matrices(n: usize) -> (CscMatrix, CscMatrix) {
    let mut rng = SplitMix64::new(7);
    let mut stiffness = Vec::new();
    let mut mass = Vec::new();
    for i in 0..n {
        stiffness.push((i, i, 4.0 + rng.next_signed().abs()));
        mass.push((i, i, 1.0 + rng.next_signed().abs()));
        for offset in [1usize, 7] {
            if i + offset < n {
                let value = -0.5 * rng.next_signed().abs();
                stiffness.push((i, i + offset, value));
                stiffness.push((i + offset, i, value));
            }
        }
    }
    (
        CscMatrix::from_triplets(n, n, stiffness),
        CscMatrix::from_triplets(n, n, mass),
    )
}

/// A 3D grid Laplacian (7-point stencil, `side³` unknowns) with a mass term, and its
/// node grouping for the nested-dissection ordering.
fn grid(side: usize) -> (CscMatrix, CscMatrix, Vec<[Option<u32>; 3]>) {
    let n = side * side * side;
    let index = |i: usize, j: usize, k: usize| (k * side + j) * side + i;
    let mut stiffness = Vec::new();
    for k in 0..side {
        for j in 0..side {
            for i in 0..side {
                let p = index(i, j, k);
                stiffness.push((p, p, 6.0));
                for (di, dj, dk) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
                    let (a, b, c) = (i + di, j + dj, k + dk);
                    if a < side && b < side && c < side {
                        let q = index(a, b, c);
                        stiffness.push((p, q, -1.0));
                        stiffness.push((q, p, -1.0));
                    }
                }
            }
        }
    }
    let mass = CscMatrix::from_triplets(n, n, (0..n).map(|i| (i, i, 1.0)).collect());
    // One unknown per node: the ordering groups by node.
    let groups = (0..n).map(|i| [Some(i as u32), None, None]).collect();
    (CscMatrix::from_triplets(n, n, stiffness), mass, groups)
}

/// The subtree sweeps against faer's sequential ones: equal to round-off, and the same
/// bits on one thread and on three.
#[test]
fn a_light_factor_is_swept_sequentially_as_faer_sweeps_it() {
    // A few hundred unknowns: waking tasks would cost more than the sweep.
    let (K, M, groups) = grid(4);
    let n = K.n_rows;
    let cholesky =
        Cholesky::new(&[(1.0, &K), (0.5, &M)], &groups, &[], Par::Seq).expect("positive definite");
    assert_eq!(cholesky.parallel_subtrees(), 0);
    let mut random = SplitMix64::new(5);
    let b: Vec<f64> = (0..n).map(|_| random.next_signed()).collect();
    let mut reference = Mat::from_fn(n, 1, |i, _| b[i]);
    cholesky.forward_in_place(reference.as_mut(), Par::Seq);
    cholesky.backward_in_place(reference.as_mut(), Par::Seq);
    let mut y = b.clone();
    cholesky.forward_vector(&mut y);
    cholesky.backward_vector(&mut y);
    let scale = reference.col(0).iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let worst = y
        .iter()
        .zip(reference.col(0).iter())
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(worst < 1e-13 * scale, "{worst:e}");
}

#[test]
fn subtree_sweeps_equal_the_sequential_ones_on_any_thread_count() {
    let (K, M, groups) = grid(14);
    let n = K.n_rows;
    let interface: Vec<usize> = (0..n).step_by(97).collect();
    let cholesky = Cholesky::new(&[(1.0, &K), (0.5, &M)], &groups, &interface, Par::Seq)
        .expect("positive definite");
    assert!(
        cholesky.parallel_subtrees() >= 4,
        "{}",
        cholesky.parallel_subtrees()
    );
    let mut random = SplitMix64::new(11);
    let b: Vec<f64> = (0..n).map(|_| random.next_signed()).collect();
    let mut reference = Mat::from_fn(n, 1, |i, _| b[i]);
    cholesky.forward_in_place(reference.as_mut(), Par::Seq);
    let forward: Vec<f64> = reference.col(0).iter().copied().collect();
    cholesky.backward_in_place(reference.as_mut(), Par::Seq);
    let sweep = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool")
            .install(|| {
                let mut y = b.clone();
                cholesky.forward_vector(&mut y);
                let after_forward = y.clone();
                cholesky.backward_vector(&mut y);
                (after_forward, y)
            })
    };
    let (forward_one, solution_one) = sweep(1);
    let (forward_three, solution_three) = sweep(3);
    assert!(forward_one == forward_three && solution_one == solution_three);
    let relative = |got: &[f64], want: &[f64]| {
        let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        got.iter()
            .zip(want)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
            / scale
    };
    let want: Vec<f64> = reference.col(0).iter().copied().collect();
    assert!(relative(&forward_one, &forward) < 1e-13);
    assert!(relative(&solution_one, &want) < 1e-13);
    // solve_vector: the permutation around the two sweeps.
    let mut x = b.clone();
    cholesky.solve_vector(&mut x);
    let residual: f64 = {
        let Ax = K.mul_vec(&x);
        let Mx = M.mul_vec(&x);
        (0..n)
            .map(|i| (Ax[i] + 0.5 * Mx[i] - b[i]).abs())
            .fold(0.0, f64::max)
    };
    assert!(residual < 1e-12, "residual {residual:e}");
}

/// `InterfaceSolve::solve` against a direct solve of `A x = b + Gᵀ r`, `A = K + 3 M`:
/// the free quantities it hands the reaction are `G A⁻¹ b`, the Delassus operator is
/// `G A⁻¹ Gᵀ`, the solution `A⁻¹ (b + Gᵀ r)`; the response is kept or not as `response_kept` says.
fn check_split_solve(
    (K, M): (&CscMatrix, &CscMatrix),
    interface: &[usize],
    G_rows: &[Vec<(usize, f64)>],
    response_kept: bool,
) {
    let n = K.n_cols;
    let terms = [(1.0, K), (3.0, M)];
    let cholesky = Cholesky::new(&terms, &[], interface, Par::Seq).unwrap();
    let interface_solve = InterfaceSolve::new(&cholesky, G_rows);
    assert_eq!(interface_solve.has_response(), response_kept);
    let mut rng = SplitMix64::new(3);
    let b: Vec<f64> = (0..n).map(|_| rng.next_signed().abs() - 0.5).collect();
    let r: Vec<f64> = (0..G_rows.len())
        .map(|i| [0.3, -1.2, 2.0][i % 3] * (1.0 + i as f64))
        .collect();
    let direct = |reaction: &[f64]| -> Vec<f64> {
        let mut rhs = Mat::from_fn(n, 1, |i, _| b[i]);
        for (row, entries) in G_rows.iter().enumerate() {
            for &(unknown, coefficient) in entries {
                rhs[(unknown, 0)] += coefficient * reaction[row];
            }
        }
        cholesky.solve_in_place(rhs.as_mut(), Par::Seq);
        rhs.col(0).iter().copied().collect()
    };
    let G_times = |x: &[f64]| -> Vec<f64> {
        G_rows
            .iter()
            .map(|entries| entries.iter().map(|&(u, c)| c * x[u]).sum())
            .collect()
    };
    let (x_direct, g_free_direct) = (direct(&r), G_times(&direct(&vec![0.0; r.len()])));
    let (mut g_free, mut y, mut x) = (vec![0.0; r.len()], vec![0.0; n], vec![0.0; n]);
    interface_solve
        .solve(&cholesky, &b, (&mut g_free, &mut y, &mut x), |free| {
            for (split, direct) in free.iter().zip(&g_free_direct) {
                assert!((split - direct).abs() < 1e-13, "{split} vs {direct}");
            }
            Ok::<_, ()>(&r[..])
        })
        .unwrap();
    for (split, direct) in x.iter().zip(&x_direct) {
        assert!((split - direct).abs() < 1e-13, "{split} vs {direct}");
    }
    let W_r = &interface_solve.W * Mat::from_fn(r.len(), 1, |i, _| r[i]);
    for (row, g) in G_times(&x_direct).iter().enumerate() {
        let g_split = g_free[row] + W_r[(row, 0)];
        assert!((g_split - g).abs() < 1e-13, "{g_split} vs {g}");
    }
}

/// A few interface unknowns eliminated last: `Y` lives on a few rows, read twice.
#[test]
fn split_solve_through_a_short_y_equals_a_direct_solve() {
    let n = 60;
    let (K, M) = matrices(n);
    let G_rows = vec![
        vec![(5, 1.0), (17, -1.0)],
        vec![(40, 0.6), (41, 0.8)],
        vec![(17, 1.0)],
    ];
    let interface = [5usize, 17, 40, 41];
    let cholesky = Cholesky::new(&[(1.0, &K), (3.0, &M)], &[], &interface, Par::Seq).unwrap();
    assert!(InterfaceSolve::new(&cholesky, &G_rows).rows.len() <= interface.len());
    check_split_solve((&K, &M), &interface, &G_rows, false);
}

/// Most unknowns on the interface of a dense matrix (a reduced model's case): `Y` fills
/// its rows, and the response is read once instead.
#[test]
fn split_solve_through_the_response_equals_a_direct_solve() {
    let n = 30;
    let mut rng = SplitMix64::new(11);
    let B = Mat::from_fn(n, n, |_, _| rng.next_signed());
    let dense = &B * B.transpose();
    let K = CscMatrix::from_triplets(
        n,
        n,
        (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .map(|(i, j)| (i, j, dense[(i, j)] + if i == j { 1.0 } else { 0.0 }))
            .collect(),
    );
    let M = CscMatrix::from_triplets(n, n, (0..n).map(|i| (i, i, 1.0)).collect());
    let G_rows: Vec<Vec<(usize, f64)>> = (0..18).map(|k| vec![(k, 1.0), (k + 12, -0.5)]).collect();
    check_split_solve((&K, &M), &[], &G_rows, true);
}

#[test]
fn an_indefinite_matrix_is_refused() {
    let (K, M) = matrices(20);
    let error = Cholesky::new(&[(1.0, &K), (-10.0, &M)], &[], &[], Par::Seq)
        .err()
        .expect("K - 10 M is indefinite");
    assert!(
        error.to_string().contains("not positive definite"),
        "{error}"
    );
}

use super::*;
use crate::cholesky::{Cholesky, InterfaceSolve};

fn analysed(terms: &[(f64, &CscMatrix)]) -> Analysis {
    Cholesky::analyse(terms, &[], &[]).unwrap()
}
use crate::rng::SplitMix64;

/// Two separate parts (a dense block of 30 unknowns and a banded one of 50), interleaved
/// in numbering, with unknowns of very different scales, plus an unknown alone; contact
/// rows that join the two parts.
fn parts() -> (CscMatrix, CscMatrix, Vec<Vec<(usize, f64)>>) {
    let mut rng = SplitMix64::new(7);
    let n = 81;
    // Even unknowns below 60 and 60..80 form the dense part; odd ones below 60 the band,
    // 80 is alone.
    let dense: Vec<usize> = (0..60).step_by(2).chain(60..80).collect();
    let band: Vec<usize> = (1..60).step_by(2).collect();
    let scale = |unknown: usize| if unknown.is_multiple_of(3) { 1e4 } else { 1.0 };
    let mut a = Vec::new();
    let mut b = Vec::new();
    for (k, &i) in dense.iter().enumerate() {
        for &j in &dense[..=k] {
            let value = if i == j {
                60.0
            } else {
                0.5 * rng.next_signed()
            };
            let value = value * scale(i) * scale(j);
            a.push((i, j, value));
            b.push((i, j, 0.1 * value));
            if i != j {
                a.push((j, i, value));
                b.push((j, i, 0.1 * value));
            }
        }
    }
    for (k, &i) in band.iter().enumerate() {
        a.push((i, i, 4.0 * scale(i) * scale(i)));
        b.push((i, i, 1.0));
        if k > 0 {
            let j = band[k - 1];
            let value = -scale(i) * scale(j);
            a.push((i, j, value));
            a.push((j, i, value));
        }
    }
    a.push((80, 80, 3.0));
    b.push((80, 80, 0.5));
    let G_rows = (0..12)
        .map(|p| vec![(2 * p, 1.0), (2 * p + 1, -1.0), (61 + p, 0.5)])
        .collect();
    (
        CscMatrix::from_triplets(n, n, a),
        CscMatrix::from_triplets(n, n, b),
        G_rows,
    )
}

/// The split solve by the inverse's blocks agrees with the one by the sparse factor, and
/// `W` with `Yᵀ Y`, to a few ulps of their size; `W` is exactly symmetric; the blocks are
/// the parts.
#[test]
fn the_blocks_solve_as_the_factor_does() {
    let (A, B, G_rows) = parts();
    let n = A.n_rows;
    let terms = [(1.0, &A), (2.0, &B)];
    let components = Components::of(&[&A, &B]);
    assert_eq!(components.members.len(), 3);
    assert_eq!(components.dense_len(), 50 * 51 / 2 + 30 * 31 / 2 + 1);
    let inverse = BlockInverse::new(&analysed(&terms), &components).unwrap();
    let split = BlockInterfaceSolve::new(&inverse, &G_rows);
    assert_eq!(inverse.entries(), components.dense_len());
    assert_eq!(split.contact_rows(&inverse), 80);
    let cholesky = Cholesky::new(&terms, &[], &[], Par::Seq).unwrap();
    let interface = InterfaceSolve::new(&cholesky, &G_rows);

    let m = G_rows.len();
    let W_scale = (0..m)
        .map(|i| interface.W[(i, i)].abs())
        .fold(0.0, f64::max);
    for i in 0..m {
        for j in 0..m {
            assert_eq!(split.W[(i, j)], split.W[(j, i)]);
            let gap = (split.W[(i, j)] - interface.W[(i, j)]).abs();
            assert!(gap <= 1e-13 * W_scale, "W[{i},{j}] off by {gap:e}");
        }
    }

    let mut rng = SplitMix64::new(11);
    let b: Vec<f64> = (0..n).map(|_| 0.5 * rng.next_signed()).collect();
    let reactions: Vec<f64> = (0..m).map(|k| k as f64 - 4.0).collect();
    let solve = |by_blocks: bool| {
        let (mut g_free, mut y, mut x) = (vec![0.0; m], vec![0.0; n], vec![0.0; n]);
        let mut seen = Vec::new();
        let react = |g: &[f64]| {
            seen = g.to_vec();
            Ok::<_, ()>(&reactions[..])
        };
        if by_blocks {
            split.solve(&inverse, &b, (&mut g_free, &mut y, &mut x), react)
        } else {
            interface.solve(&cholesky, &b, (&mut g_free, &mut y, &mut x), react)
        }
        .unwrap();
        (seen, x)
    };
    let (g_blocks, x_blocks) = solve(true);
    let (g_factor, x_factor) = solve(false);
    let size = |v: &[f64]| v.iter().fold(0.0_f64, |a, b| a.max(b.abs()));
    for (a, b) in g_blocks.iter().zip(&g_factor) {
        assert!((a - b).abs() <= 1e-13 * size(&g_factor));
    }
    for (a, b) in x_blocks.iter().zip(&x_factor) {
        assert!((a - b).abs() <= 1e-13 * size(&x_factor));
    }
    // x solves A x = b + Gᵀ r, each row to rounding of its terms.
    let mut rhs = b.clone();
    for (row, r) in G_rows.iter().zip(&reactions) {
        for &(unknown, value) in row {
            rhs[unknown] += value * r;
        }
    }
    let x_abs: Vec<f64> = x_blocks.iter().map(|x| x.abs()).collect();
    let abs = |M: &CscMatrix| CscMatrix {
        values: M.values.iter().map(|v| v.abs()).collect(),
        ..M.clone()
    };
    let (A_abs, B_abs) = (abs(&A), abs(&B));
    let (A_x, B_x) = (A.mul_vec(&x_blocks), B.mul_vec(&x_blocks));
    let (A_abs_x, B_abs_x) = (A_abs.mul_vec(&x_abs), B_abs.mul_vec(&x_abs));
    for i in 0..n {
        let residual = A_x[i] + 2.0 * B_x[i] - rhs[i];
        let terms = A_abs_x[i] + 2.0 * B_abs_x[i] + rhs[i].abs();
        assert!(
            residual.abs() <= 1e-12 * terms,
            "row {i}: {residual:e} of {terms:e}"
        );
    }
}

/// The condition of a block scaled to a unit diagonal, against `[[1, a], [a, 1]]`'s
/// `(1 + |a|)/(1 − |a|)`; a diagonal block's is 1.
#[test]
fn the_condition_is_that_of_the_scaled_blocks() {
    let a = 0.5;
    let A = CscMatrix::from_triplets(
        3,
        3,
        vec![
            (0, 0, 4.0),
            (0, 1, 2.0 * 9.0 * a),
            (1, 0, 2.0 * 9.0 * a),
            (1, 1, 81.0),
            (2, 2, 7.0),
        ],
    );
    let components = Components::of(&[&A]);
    let inverse = BlockInverse::new(&analysed(&[(1.0, &A)]), &components).unwrap();
    let expected = (1.0 + a) / (1.0 - a);
    assert!((inverse.condition() - expected).abs() <= 1e-14 * expected);
    let D = CscMatrix::from_triplets(2, 2, vec![(0, 0, 1e-6), (1, 1, 1e6)]);
    let components = Components::of(&[&D]);
    let inverse = BlockInverse::new(&analysed(&[(1.0, &D)]), &components).unwrap();
    assert_eq!(inverse.condition(), 1.0);
}

/// A block that is not positive definite is named, not inverted.
#[test]
fn an_indefinite_block_is_an_error_naming_it() {
    let A = CscMatrix::from_triplets(
        3,
        3,
        vec![
            (0, 0, 1.0),
            (1, 1, 1.0),
            (1, 2, 2.0),
            (2, 1, 2.0),
            (2, 2, 1.0),
        ],
    );
    let components = Components::of(&[&A]);
    let err = BlockInverse::new(&analysed(&[(1.0, &A)]), &components)
        .err()
        .expect("an indefinite block");
    let message = err.to_string();
    assert!(
        message.contains("2 x 2 block of unknowns 1..=2"),
        "{message}"
    );
}

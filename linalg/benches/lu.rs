//! One-vector solves with a single-precision LU of the contact chord's size (864 unknowns: the
//! default brake's 288 pairs, all closed), by `squeal_linalg::lu::PackedLu` and by faer's
//! `PartialPivLu`, back to back, three rounds. Run with
//! `cargo bench -p squeal-linalg --bench lu`.

#![allow(non_snake_case)] // matrices are named as in the equations

mod common;

use std::hint::black_box;

use common::median_seconds;
use faer::Mat;
use faer::linalg::solvers::{PartialPivLu, Solve};
use squeal_linalg::lu::PackedLu;

fn main() {
    let n = 864;
    // Diagonally heavy, as the chord's Jacobian (its rows scaled by 1/W_ii) is.
    let A = Mat::<f32>::from_fn(n, n, |i, j| {
        ((i * n + j) as f32 * 0.618).sin() + if i == j { 30.0 } else { 0.0 }
    });
    let b: Vec<f32> = (0..n).map(|i| ((i * 13) % 7) as f32 - 3.0).collect();
    let packed = PackedLu::new(A.as_ref());
    let by_faer = PartialPivLu::new(A.as_ref());
    println!("{n} unknowns, single precision, median of 2001 solves");
    for round in 1..=3 {
        let packed_s = median_seconds(2001, || {
            let mut x = b.clone();
            packed.solve_in_place(&mut x);
            black_box(&x);
        });
        let faer_s = median_seconds(2001, || {
            black_box(by_faer.solve(Mat::from_fn(n, 1, |i, _| b[i])));
        });
        println!(
            "round {round}: packed {:.1} µs, faer {:.1} µs ({:.2}×)",
            1e6 * packed_s,
            1e6 * faer_s,
            faer_s / packed_s
        );
    }
}

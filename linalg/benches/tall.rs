//! `Qᴴ W` and `X += Q C` for the Krylov basis's shape (28,224 rows: the default brake's
//! reduced DOFs; 480 and 960 columns; blocks of 8 and 16), by `squeal_linalg::tall` and by faer's
//! general product, on one thread and on all; and a Gram–Schmidt update with the next projection,
//! apart and fused. Run with
//! `cargo bench -p squeal-linalg --bench tall`.

#![allow(non_snake_case)] // matrices are named as in the equations

mod common;

use common::median_seconds;
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatMut, MatRef, Par, c64};
use squeal_linalg::tall::{add_times, adjoint_times, subtract_then_adjoint_times};

fn main() {
    let rows = 28_224;
    println!("{rows} rows, median of 9 runs, GFLOP/s counting 8 per complex multiply-add");
    for columns in [480, 960] {
        let Q = Mat::<c64>::from_fn(rows, columns, |i, j| {
            c64::new(
                ((i * 7 + j * 13) % 17) as f64 - 8.0,
                ((i + 3 * j) % 5) as f64 - 2.0,
            )
        });
        for width in [8, 16] {
            let W = Mat::<c64>::from_fn(rows, width, |i, j| {
                c64::new(((i + 5 * j) as f64).cos(), ((3 * i + j) as f64).sin())
            });
            let flop = 8.0 * (rows * columns * width) as f64;
            for (threads, par) in [("1 thread", Par::Seq), ("all threads", Par::rayon(0))] {
                compare(
                    "Qᴴ W  ",
                    (columns, width, threads, flop),
                    (columns, width),
                    |out| {
                        matmul(
                            out,
                            Accum::Replace,
                            Q.adjoint(),
                            W.as_ref(),
                            c64::new(1.0, 0.0),
                            par,
                        )
                    },
                    |mut out| out.copy_from(adjoint_times(Q.as_ref(), W.as_ref(), par)),
                );
                let C = Mat::<c64>::from_fn(columns, width, |i, j| {
                    c64::new(((2 * i + j) as f64).sin(), ((i + 7 * j) as f64).cos())
                });
                compare(
                    "X += Q C",
                    (columns, width, threads, flop),
                    (rows, width),
                    |out| {
                        matmul(
                            out,
                            Accum::Add,
                            Q.as_ref(),
                            C.as_ref(),
                            c64::new(1.0, 0.0),
                            par,
                        )
                    },
                    |out| add_times(out, Q.as_ref(), C.as_ref(), par),
                );
                if threads == "all threads" {
                    fused(Q.as_ref(), W.as_ref(), C.as_ref(), (columns, width, par));
                }
            }
        }
    }
}

/// Times faer's product and ours, each writing into a zeroed matrix of `shape`, and prints one
/// line of the table: times, rates, the ratio, and how far the results differ. The case is
/// named by the basis's columns, the block's width, the threads and the flop count.
fn compare(
    product: &str,
    (columns, width, threads, flop): (usize, usize, &str, f64),
    shape: (usize, usize),
    mut faer_product: impl FnMut(MatMut<'_, c64>),
    mut our_product: impl FnMut(MatMut<'_, c64>),
) {
    let mut reference = Mat::<c64>::zeros(shape.0, shape.1);
    let faer_seconds = median_seconds(9, || faer_product(reference.as_mut()));
    let mut ours = Mat::<c64>::zeros(shape.0, shape.1);
    let ours_seconds = median_seconds(9, || our_product(ours.as_mut()));
    let difference = (&ours - &reference).norm_max() / reference.norm_max();
    println!(
        "  {product} {columns:4} × {width:2}, {threads:11}: tall {:6.1} ms ({:4.1} GFLOP/s), faer {:6.1} ms ({:4.1} GFLOP/s): {:.2}× (relative difference {difference:.1e})",
        ours_seconds * 1e3,
        flop / ours_seconds / 1e9,
        faer_seconds * 1e3,
        flop / faer_seconds / 1e9,
        faer_seconds / ours_seconds
    );
}

/// `W −= Q C` then `Qᴴ W`: the two products one after the other, and fused in one sweep over
/// `Q` (`subtract_then_adjoint_times`).
fn fused(Q: MatRef<'_, c64>, W: MatRef<'_, c64>, C: MatRef<'_, c64>, shape: (usize, usize, Par)) {
    let (columns, width, par) = shape;
    let apart = median_seconds(9, || {
        let mut z = W.to_owned();
        add_times(z.as_mut(), Q, (-C).as_ref(), par);
        adjoint_times(Q, z.as_ref(), par);
    });
    let together = median_seconds(9, || {
        let mut z = W.to_owned();
        subtract_then_adjoint_times(z.as_mut(), Q, C, par);
    });
    println!(
        "  W −= Q C, then Qᴴ W {columns:4} × {width:2}, all threads: apart {:6.1} ms, fused {:6.1} ms: {:.2}×",
        apart * 1e3,
        together * 1e3,
        apart / together
    );
}

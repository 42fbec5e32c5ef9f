//! Assembly and real modes of a brake-disc-sized annulus: wall time of `assemble` for ~30,000
//! and ~300,000 DOFs, and the lowest 100 modes of the ~30,000-DOF model (factorisation time,
//! Lanczos figures, worst residual, Sturm count).
//!
//! ```text
//! cargo bench -p squeal-stages --bench modes            # everything
//! cargo bench -p squeal-stages --bench modes -- small   # skip the 300k assembly
//! python3 stages/benches/scipy_eigsh.py <dir printed below>   # scipy on the same K and M
//! ```
//!
//! The 30k model's `K` and `M` are written as Matrix Market files (symmetric, lower triangle,
//! 1-based) for the scipy comparison.

#![allow(non_snake_case)] // matrices are named as in the equations

use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;
use std::time::Instant;

use faer::Par;
use squeal_stages::assemble::{Assemble, assemble_model};
use squeal_stages::mesh::structured;
use squeal_stages::model::{CscMatrix, Model};
use squeal_stages::modes::eigensolver::{Band, solve};
use squeal_stages::{Params, Stage};

/// A disc 0.15–0.32 m in radius, 45 mm thick, clamped at the hub (the inner cylinder).
fn disc_model(counts: [usize; 3]) -> (Model, f64) {
    let mesh = structured::annulus(0.15, 0.32, 0.0, 0.045, counts, "disc");
    let params = Params(
        Assemble
            .params()
            .into_iter()
            .filter_map(|spec| spec.default.map(|value| (spec.name.to_string(), value)))
            .collect::<BTreeMap<_, _>>(),
    );
    let started = Instant::now();
    let (model, _) = assemble_model(&mesh, &params, &["inner".to_string()])
        .unwrap_or_else(|err| panic!("assembly failed: {err}"));
    (model, started.elapsed().as_secs_f64())
}

fn best_assembly_seconds(counts: [usize; 3], runs: usize) -> (Model, f64) {
    let (model, mut best) = disc_model(counts);
    for _ in 1..runs {
        best = best.min(disc_model(counts).1);
    }
    (model, best)
}

fn write_matrix_market(path: &Path, A: &CscMatrix) -> std::io::Result<()> {
    let mut lower = Vec::new();
    for col in 0..A.n_cols {
        for entry in A.col_ptr[col]..A.col_ptr[col + 1] {
            let row = A.row_idx[entry];
            if row >= col && A.values[entry] != 0.0 {
                lower.push((row, col, A.values[entry]));
            }
        }
    }
    let mut file = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(file, "%%MatrixMarket matrix coordinate real symmetric")?;
    writeln!(file, "{} {} {}", A.n_rows, A.n_cols, lower.len())?;
    for (row, col, value) in lower {
        writeln!(file, "{} {} {:.17e}", row + 1, col + 1, value)?;
    }
    file.flush()
}

fn main() {
    let small_only = std::env::args().any(|arg| arg == "small");
    let threads = rayon::current_num_threads();
    println!("threads: {threads}");

    let (model, seconds) = best_assembly_seconds([12, 200, 3], 3);
    println!(
        "assemble ~30k: {} DOFs, {} elements, nnz(K) = {}, best of 3: {:.3} s",
        model.n_dofs(),
        model.mesh.hexes.len(),
        model.K.values.len(),
        seconds
    );

    if std::env::args().any(|arg| arg == "solve-scan") {
        use squeal_stages::modes::factor::ShiftedPencil;
        let pencil = ShiftedPencil::new(&model.K, &model.M, &model.dof_of_node).unwrap();
        for par in [Par::Seq, Par::rayon(0)] {
            let factor = pencil.factor(-1.0, par).unwrap();
            for block in [1usize, 4, 8, 16, 32, 64] {
                let mut rhs = faer::Mat::<f64>::from_fn(model.n_dofs(), block, |i, j| {
                    ((i * 7 + j * 13) % 17) as f64
                });
                let started = Instant::now();
                let repeats = (64 / block).max(2);
                for _ in 0..repeats {
                    factor.solve_in_place(rhs.as_mut(), par);
                }
                let seconds = started.elapsed().as_secs_f64() / repeats as f64;
                println!(
                    "{par:?} block {block}: {:.4} s per solve, {:.5} s per vector",
                    seconds,
                    seconds / block as f64
                );
            }
            let started = Instant::now();
            let _ = pencil.factor(-1.0, par).unwrap();
            println!("{par:?} factor {:.3} s", started.elapsed().as_secs_f64());
        }
        return;
    }

    if std::env::args().any(|arg| arg == "gemm-scan") {
        use faer::linalg::matmul::matmul;
        use faer::{Accum, Mat};
        let n = model.n_dofs();
        for m in [64usize, 264] {
            let Q = Mat::<f64>::from_fn(n, m, |i, j| ((i * 7 + j * 13) % 17) as f64);
            let W = Mat::<f64>::from_fn(n, 8, |i, j| ((i * 3 + j * 5) % 11) as f64);
            for par in [Par::Seq, Par::rayon(0)] {
                let mut H = Mat::<f64>::zeros(m, 8);
                let started = Instant::now();
                for _ in 0..10 {
                    matmul(
                        H.as_mut(),
                        Accum::Replace,
                        Q.transpose(),
                        W.as_ref(),
                        1.0,
                        par,
                    );
                }
                let t1 = started.elapsed().as_secs_f64() / 10.0;
                let mut W2 = W.clone();
                let started = Instant::now();
                for _ in 0..10 {
                    matmul(W2.as_mut(), Accum::Add, Q.as_ref(), H.as_ref(), -1.0, par);
                }
                let t2 = started.elapsed().as_secs_f64() / 10.0;
                let flops = 2.0 * (n * m * 8) as f64;
                println!(
                    "m {m} {par:?}: Q^T W {:.4} s ({:.1} GFlop/s), W - Q H {:.4} s ({:.1} GFlop/s)",
                    t1,
                    flops / t1 * 1e-9,
                    t2,
                    flops / t2 * 1e-9
                );
            }
        }
        let X = Mat::<f64>::from_fn(n, 8, |i, j| ((i * 3 + j * 5) % 11) as f64);
        let started = Instant::now();
        for _ in 0..10 {
            let _ = squeal_stages::modes::sparse_ops::symmetric_mul(&model.M, X.as_ref());
        }
        println!(
            "M X (8 columns): {:.4} s",
            started.elapsed().as_secs_f64() / 10.0
        );
        return;
    }
    if !small_only {
        let (large, seconds) = best_assembly_seconds([26, 640, 5], 2);
        println!(
            "assemble ~300k: {} DOFs, {} elements, nnz(K) = {}, best of 2: {:.3} s",
            large.n_dofs(),
            large.mesh.hexes.len(),
            large.K.values.len(),
            seconds
        );
    }

    let band = Band {
        n_modes: 100,
        lambda_lo: 0.0,
        lambda_hi: f64::INFINITY,
    };
    for (run, par) in [Par::rayon(0), Par::Seq].into_iter().enumerate() {
        let started = Instant::now();
        let solution = solve(&model.K, &model.M, &model.dof_of_node, band, par)
            .unwrap_or_else(|err| panic!("modes failed: {err}"));
        let wall = started.elapsed().as_secs_f64();
        let report = &solution.report;
        let frequency = |lambda: f64| lambda.sqrt() / (2.0 * std::f64::consts::PI);
        println!(
            "modes run {run} ({par:?}): 100 lowest of {} DOFs in {wall:.3} s (analyse {:.3} s with {}, {} numeric factorisations {:.3} s total, factor {} entries; Lanczos {:.3} s = solves {:.3} + reorthogonalisation {:.3} + Ritz {:.3}, basis {}, restarts {}, {} vectors solved; refinement {:.3} s in {} steps)",
            report.n_dofs,
            report.analyse_seconds,
            if report.nested_dissection {
                "METIS nested dissection"
            } else {
                "AMD"
            },
            report.n_factorizations,
            report.factor_seconds,
            report.factor_entries,
            report.lanczos_seconds,
            report.solve_seconds,
            report.orthogonalize_seconds,
            report.ritz_seconds,
            report.basis_size,
            report.restarts,
            report.n_solves,
            report.refine_seconds,
            report.refinement_steps,
        );
        println!(
            "    f1 = {:.2} Hz, f100 = {:.2} Hz, worst residual {:.2e}, Sturm count {} below {:.2} Hz = {} found",
            frequency(solution.lambda[0]),
            frequency(solution.lambda[99]),
            report.worst_residual,
            report.sturm_count,
            frequency(report.sturm_shift),
            report.found_below_sturm_shift
        );
    }

    let directory = Path::new(env!("CARGO_TARGET_TMPDIR")).join("modes-bench");
    std::fs::create_dir_all(&directory).expect("create the bench directory");
    write_matrix_market(&directory.join("K.mtx"), &model.K).expect("write K.mtx");
    write_matrix_market(&directory.join("M.mtx"), &model.M).expect("write M.mtx");
    println!(
        "Matrix Market files: {} (python3 stages/benches/scipy_eigsh.py <that directory>)",
        directory.display()
    );
}

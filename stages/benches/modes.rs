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

use std::path::Path;
use std::time::Instant;

use squeal_linalg::eigensolver::{Band, SolveOptions, solve};
use squeal_linalg::ldlt::{FillOrdering, ShiftedPencil};
use squeal_stages::artifact::{CscMatrix, Model};
use squeal_stages::assemble::{Assemble, assemble_model};
use squeal_stages::mesh::structured;
use squeal_stages::{Params, Value};

/// A disc 0.15–0.32 m in radius, 45 mm thick, clamped at the hub (the inner cylinder).
fn disc_model(counts: [usize; 3]) -> (Model, f64) {
    let mesh = structured::annulus(0.15, 0.32, 0.0, 0.045, counts, "disc");
    let params = Params::defaults(&Assemble, &[("clamped", Value::Str("inner".into()))])
        .read::<Assemble>()
        .expect("the default materials read");
    let started = Instant::now();
    let (model, _) =
        assemble_model(&mesh, &params).unwrap_or_else(|err| panic!("assembly failed: {err}"));
    (model, started.elapsed().as_secs_f64())
}

fn best_assembly_seconds(counts: [usize; 3], runs: usize) -> (Model, f64) {
    let (model, mut best) = disc_model(counts);
    for _ in 1..runs {
        best = best.min(disc_model(counts).1);
    }
    (model, best)
}

/// `A` as Matrix Market text, by the writer squeal's `matrix_market` stage uses.
fn write_matrix_market(path: &Path, A: &CscMatrix) -> std::io::Result<()> {
    let text = squeal_linalg::matrix_market::write_matrix_market(A, "modes benchmark")
        .map_err(std::io::Error::other)?;
    std::fs::write(path, text)
}

fn main() {
    let small_only = std::env::args().any(|arg| arg == "small");
    println!("threads: {}", rayon::current_num_threads());

    let (model, seconds) = best_assembly_seconds([12, 200, 3], 3);
    println!(
        "assemble ~30k: {} DOFs, {} elements, nnz(K) = {}, best of 3: {:.3} s",
        model.n_dofs(),
        model.mesh.elements.len(),
        model.K.values.len(),
        seconds
    );

    if !small_only {
        let (large, seconds) = best_assembly_seconds([26, 640, 5], 2);
        println!(
            "assemble ~300k: {} DOFs, {} elements, nnz(K) = {}, best of 2: {:.3} s",
            large.n_dofs(),
            large.mesh.elements.len(),
            large.K.values.len(),
            seconds
        );
    }

    let band = Band {
        n_modes: 100,
        lambda_lo: 0.0,
        lambda_hi: f64::INFINITY,
    };
    // The fill-reducing ordering: METIS nested dissection against faer's minimum degree.
    for fill_ordering in [FillOrdering::NestedDissection, FillOrdering::MinimumDegree] {
        let started = Instant::now();
        let pencil =
            ShiftedPencil::with_ordering(&model.K, &model.M, &model.dof_of_node, fill_ordering)
                .unwrap_or_else(|err| panic!("analysis failed: {err}"));
        let analyse = started.elapsed().as_secs_f64();
        let mut best = f64::INFINITY;
        for _ in 0..3 {
            let started = Instant::now();
            pencil
                .factor(-1.0, faer::Par::Seq)
                .unwrap_or_else(|err| panic!("factorisation failed: {err}"));
            best = best.min(started.elapsed().as_secs_f64());
        }
        println!(
            "LDL^T of K - sigma M with {fill_ordering:?}: analyse {analyse:.3} s, factorise {best:.3} s (best of 3), {} entries in L",
            pencil.factor_len()
        );
    }

    // Defaults (residual ≤ 1e-9 after refinement), then refined to the level ARPACK reaches.
    let tight = SolveOptions {
        refined_residual: 1e-11,
        ..SolveOptions::default()
    };
    for (label, options) in [("default", SolveOptions::default()), ("tight", tight)] {
        let started = Instant::now();
        let solution = solve(&model.K, &model.M, &model.dof_of_node, band, options)
            .unwrap_or_else(|err| panic!("modes failed: {err}"));
        let wall = started.elapsed().as_secs_f64();
        let report = &solution.report;
        let frequency = |lambda: f64| lambda.sqrt() / (2.0 * std::f64::consts::PI);
        println!(
            "modes ({label}, refined to {:.0e}): 100 lowest of {} DOFs in {wall:.3} s",
            options.refined_residual, report.n_dofs
        );
        println!(
            "    analyse {:.3} s ({}), {} numeric factorisations {:.3} s in all, factor {} entries",
            report.analyse_seconds,
            if report.nested_dissection {
                "METIS nested dissection"
            } else {
                "AMD"
            },
            report.n_factorizations,
            report.factor_seconds,
            report.factor_entries,
        );
        println!(
            "    Lanczos {:.3} s: solves {:.3} s ({} vectors in all), reorthogonalisation {:.3} s, Ritz {:.3} s; basis {}, restarts {}",
            report.lanczos_seconds,
            report.solve_seconds,
            report.n_solves,
            report.orthogonalize_seconds,
            report.ritz_seconds,
            report.basis_size,
            report.restarts,
        );
        println!(
            "    refinement {:.3} s in {} steps; f1 = {:.2} Hz, f100 = {:.2} Hz, worst residual {:.2e}; Sturm count {} below {:.2} Hz, {} found",
            report.refine_seconds,
            report.refinement_steps,
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

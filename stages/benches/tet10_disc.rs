//! A brake disc meshed with 10-node tetrahedra, as a CAD mesher gives it: assembly time and
//! peak memory at about a million DOFs, and the lowest 50 modes at about 300,000 DOFs, with its
//! `K` and `M` written for the same solve by scipy.
//!
//! ```text
//! cargo bench -p squeal-stages --bench tet10_disc -- assembly   # ~1M DOFs
//! cargo bench -p squeal-stages --bench tet10_disc -- modes      # ~300k DOFs, 50 modes
//! python3 stages/benches/scipy_eigsh.py <directory printed> 50  # scipy on the same K and M
//! ```
//!
//! The disc (0.15–0.32 m in radius, 45 mm thick, clamped on its inner cylinder) is a
//! structured annulus of hexahedra split into six tetrahedra each, with mid-edge nodes.

#![allow(non_snake_case)] // matrices are named as in the equations

use std::path::Path;
use std::time::Instant;

use squeal_linalg::eigensolver::{Band, SolveOptions, solve};
use squeal_stages::artifact::{ElementKind, Mesh};
use squeal_stages::assemble::{Assemble, assemble_model};
use squeal_stages::mesh::{convert, structured};
use squeal_stages::{Params, Value};

fn disc(counts: [usize; 3]) -> Mesh {
    let hexahedra = structured::annulus(0.15, 0.32, 0.0, 0.045, counts, "disc");
    convert::as_kind(&hexahedra, ElementKind::Tet10)
}

/// A line of `/proc/self/status` in MiB (`VmRSS`: now, `VmHWM`: the peak so far).
fn memory_mib(field: &str) -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find(|line| line.starts_with(field))
        .and_then(|line| line.split_whitespace().nth(1)?.parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

fn assemble(mesh: &Mesh) -> (squeal_stages::artifact::Model, f64) {
    let params = Params::defaults(&Assemble, &[("clamped", Value::Str("inner".into()))])
        .read::<Assemble>()
        .expect("the default materials read");
    let started = Instant::now();
    let (model, _) =
        assemble_model(mesh, &params).unwrap_or_else(|err| panic!("assembly failed: {err}"));
    (model, started.elapsed().as_secs_f64())
}

fn assembly() {
    let mesh = disc([16, 300, 8]);
    let before = memory_mib("VmRSS:");
    let (model, seconds) = assemble(&mesh);
    println!(
        "assemble ~1M: {} DOFs, {} tet10, nnz(K) = {}, {seconds:.2} s; resident {before:.0} MiB with the mesh, peak {:.0} MiB",
        model.n_dofs(),
        mesh.elements.len(),
        model.K.values.len(),
        memory_mib("VmHWM:")
    );
}

fn modes() {
    let mesh = disc([10, 180, 6]);
    let (model, seconds) = assemble(&mesh);
    println!(
        "assemble ~300k: {} DOFs, {} tet10, nnz(K) = {}, {seconds:.2} s",
        model.n_dofs(),
        mesh.elements.len(),
        model.K.values.len()
    );
    let band = Band {
        n_modes: 50,
        lambda_lo: 0.0,
        lambda_hi: f64::INFINITY,
    };
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
            "modes ({label}, refined to {:.0e}): 50 lowest of {} DOFs in {wall:.2} s; factorisations {:.2} s ({} entries), Lanczos {:.2} s; f1 = {:.2} Hz, f50 = {:.2} Hz, worst residual {:.2e}; Sturm count {} below {:.2} Hz; peak {:.0} MiB",
            options.refined_residual,
            report.n_dofs,
            report.factor_seconds,
            report.factor_entries,
            report.lanczos_seconds,
            frequency(solution.lambda[0]),
            frequency(solution.lambda[49]),
            report.worst_residual,
            report.sturm_count,
            frequency(report.sturm_shift),
            memory_mib("VmHWM:")
        );
    }
    let directory = Path::new(env!("CARGO_TARGET_TMPDIR")).join("tet10-disc-bench");
    std::fs::create_dir_all(&directory).expect("create the bench directory");
    for (name, matrix) in [("K.mtx", &model.K), ("M.mtx", &model.M)] {
        let text = squeal_linalg::matrix_market::write_matrix_market(matrix, "tet10 disc")
            .unwrap_or_else(|err| panic!("{name}: {err}"));
        std::fs::write(directory.join(name), text).unwrap_or_else(|err| panic!("{name}: {err}"));
    }
    println!(
        "Matrix Market files: {} (python3 stages/benches/scipy_eigsh.py <that directory> 50)",
        directory.display()
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let wants = |name: &str| args.iter().any(|arg| arg == name);
    println!("threads: {}", rayon::current_num_threads());
    if wants("assembly") || !wants("modes") {
        assembly();
    }
    if wants("modes") || !wants("assembly") {
        modes();
    }
}

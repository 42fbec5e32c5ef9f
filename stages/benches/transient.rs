//! The nonlinear transient of the default brake (`mesh.brake` defaults, μ = 0.38, ω = 4 rad/s,
//! interference 0.1 mm), started by a normal velocity kick of the pads' contact nodes: the
//! factorisation of J and the Delassus set-up, the cost of a step split into its solve (the
//! sparse sweeps and the interface products), the contact solve and the rest, against one plain
//! solve with J's factor (repeated, and after a cache flush, the state a step's solve meets),
//! then the whole run with its wall time and peak memory.
//! Run with `cargo bench -p squeal-stages --bench transient`. `SQUEAL_BENCH_STEPS` (20,000),
//! `SQUEAL_BENCH_TAU` (1e-6 s), `SQUEAL_BENCH_KICK` (1e-3 m/s) and `SQUEAL_BENCH_SOLVER`
//! (`active_set`, `gauss_seidel` or `fixed_point`) override the run. `SQUEAL_BENCH_BASIS=N`
//! runs it on a reduced model instead: a Craig–Bampton basis of N fixed-interface modes, which
//! like every basis kind keeps the interface's DOFs and their static modes (the kind needs no
//! stability stage, and a reduced step's cost depends on the sizes, not on the vectors).
//!
//! With `SQUEAL_EXPORT_DIR=<dir>`, M, C, K (Matrix Market), the rows of H, the pairs' data and
//! the initial velocity are written there for `transient_scipy.py`, the same scheme
//! written with scipy.

use std::io::Write;
use std::time::Instant;

use faer::{MatMut, Par};
use squeal_linalg::matrix_market::write_matrix_market;
use std::collections::BTreeMap;
use std::sync::Arc;

use squeal_stages::artifact::{Artifact, Basis, Equilibrium, Model};
use squeal_stages::assemble::with_default_materials;
use squeal_stages::basis::ReductionBasis;
use squeal_stages::contact::lcp::LcpSettings;
use squeal_stages::equilibrium::{Load, Solver, solve as equilibrium};
use squeal_stages::mesh::brake::{BrakeGeometry, brake};
use squeal_stages::stage::{Input, Inputs, Params, Value};
use squeal_stages::transient::contact::Solver as ContactSolver;
use squeal_stages::transient::reduced::ReducedModel;
use squeal_stages::transient::scheme::{Settings, SolveBy, Structure, factorise_J, integrate};
use squeal_stages::transient::{kick, structure_of};
use squeal_stages::{NoCheckpoints, Stage};

/// Peak resident memory of this process (MiB), from /proc.
fn peak_memory_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|status| {
            status
                .lines()
                .find(|line| line.starts_with("VmHWM:"))
                .and_then(|line| line.split_whitespace().nth(1))
                .and_then(|kib| kib.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kib| kib / 1024.0)
}

fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(format!("SQUEAL_BENCH_{name}"))
        .ok()
        .and_then(|value| value.parse().ok())
        .unwrap_or(default)
}

fn main() {
    let mesh = brake(&BrakeGeometry::default()).expect("default brake");
    let (model, _) = with_default_materials(&mesh, "hub, pad_backs", &[]).expect("assembly");
    let (equilibrium, _) = equilibrium(
        &model,
        0.38,
        4.0,
        Load::Interference(1e-4),
        Solver::SemismoothNewton,
        &LcpSettings::default(),
    )
    .expect("equilibrium");
    let n_steps: usize = env_or("STEPS", 20_000);
    let tau: f64 = env_or("TAU", 1e-6);
    let (full, contact_state) = structure_of(&model, &equilibrium).expect("structure");
    let (u0, v0) = kick(&model, &equilibrium, env_or("KICK", 1e-3));
    println!(
        "default brake: {} free DOFs, {} pairs ({} closed); tau = {tau:e} s, {n_steps} steps",
        model.n_dofs(),
        equilibrium.closed.len(),
        equilibrium.closed.iter().filter(|closed| **closed).count(),
    );
    if let Ok(dir) = std::env::var("SQUEAL_EXPORT_DIR") {
        export(&dir, &full, &contact_state, &v0);
    }
    let n_modes: usize = env_or("BASIS", 0);
    let basis = (n_modes > 0).then(|| craig_bampton(&model, &equilibrium, n_modes));
    let reduced = basis
        .as_ref()
        .map(|basis| ReducedModel::new(&model, basis, &full).expect("reduced model"));
    let reduced_structure = reduced.as_ref().map(ReducedModel::structure);
    let structure = reduced_structure.as_ref().unwrap_or(&full);
    let (u0, v0) = match &basis {
        Some(basis) => {
            println!(
                "on a Craig-Bampton basis of {n_modes} modes: {} reduced unknowns",
                basis.n_reduced()
            );
            (basis.restrict(&model.M, &u0), basis.restrict(&model.M, &v0))
        }
        None => (u0, v0),
    };

    let theta = 0.5;
    let solve = plain_solve_ms(structure, theta, tau);
    // The peak memory reported is the run's: reset the high-water mark (Linux).
    let _ = std::fs::write("/proc/self/clear_refs", "5");

    let settings = Settings {
        theta,
        tau,
        n_steps,
        solver: match std::env::var("SQUEAL_BENCH_SOLVER").as_deref() {
            Ok("fixed_point") => ContactSolver::FixedPoint,
            Ok("gauss_seidel") => ContactSolver::GaussSeidel,
            _ => ContactSolver::ActiveSet,
        },
        tolerance: 1e-10,
        max_iterations: 2000,
        output_every: 1,
        record_pairs: vec![0],
        record_dofs: Vec::new(),
        record_contacts: false,
        snapshot_steps: Vec::new(),
        sample_steps: Vec::new(),
        solve_by: SolveBy::Choice,
    };
    let clock = Instant::now();
    let run = integrate(
        structure,
        &contact_state,
        &settings,
        u0,
        v0,
        &NoCheckpoints,
        |_| {},
    )
    .unwrap_or_else(|failure| panic!("the run failed: {failure:?}"));
    let wall = clock.elapsed().as_secs_f64();
    let timings = &run.timings;
    let per_step = |seconds: f64| 1e3 * seconds / n_steps as f64;
    let step_ms = per_step(timings.steps);
    println!(
        "factorisation of J {:.2} s ({} entries in L), Delassus operator {:.2} s ({} rows of Y)",
        timings.factor, run.factor_len, timings.delassus, run.interface_rows
    );
    println!(
        "per step {step_ms:.3} ms: solve {:.3} ms, contact {:.3} ms, the rest {:.3} ms",
        per_step(timings.solve),
        per_step(timings.contact),
        per_step(timings.steps - timings.solve - timings.contact),
    );
    println!(
        "one plain solve {:.3} ms repeated, {:.3} ms after a cache flush (faer's sequential sweeps: {:.3}, {:.3} ms); step / solve = {:.2} (repeated), {:.2} (flushed)",
        solve.repeated_ms,
        solve.flushed_ms,
        solve.sequential_repeated_ms,
        solve.sequential_flushed_ms,
        step_ms / solve.repeated_ms,
        step_ms / solve.flushed_ms
    );
    let last = run.history.last().expect("rows");
    println!(
        "run {wall:.1} s wall, peak memory {:.0} MiB; contact iterations {:.1} on average, {} at most, {} factorisations of the active set, worst residual {:.1e}; final open {:.2}, stick {:.2}, slide {:.2}; final kinetic energy {:.6e} J; balance error {:.2e} J of peak {:.2e} J",
        peak_memory_mib(),
        run.history
            .iter()
            .skip(1)
            .map(|row| row.contact_iterations as f64)
            .sum::<f64>()
            / (run.history.len() - 1).max(1) as f64,
        run.most_contact_iterations,
        run.contact_factorisations,
        run.worst_contact_residual,
        last.open,
        last.stick,
        last.slide,
        last.kinetic,
        run.history
            .iter()
            .map(|row| row.energy.balance_error.abs())
            .fold(0.0, f64::max),
        squeal_stages::transient::peak_energy(&run.history)
    );
}

/// The `basis` stage's Craig–Bampton basis of `n_modes` fixed-interface modes.
fn craig_bampton(model: &Model, equilibrium: &Equilibrium, n_modes: usize) -> Basis {
    let params = Params::defaults(
        &ReductionBasis,
        &[
            ("kind", Value::Str("craig_bampton".into())),
            ("n_modes", Value::Int(n_modes as i64)),
        ],
    );
    let input = |artifact: Artifact| Input::One(Arc::new(artifact));
    let inputs = Inputs(BTreeMap::from([
        (
            "model".to_string(),
            input(Artifact::Model(Box::new(model.clone()))),
        ),
        (
            "equilibrium".to_string(),
            input(Artifact::Equilibrium(Box::new(equilibrium.clone()))),
        ),
    ]));
    let clock = Instant::now();
    let mut outputs = ReductionBasis.run(&params, &inputs).expect("basis");
    println!("basis built in {:.1} s", clock.elapsed().as_secs_f64());
    match outputs.remove("basis") {
        Some(Artifact::Basis(basis)) => *basis,
        _ => panic!("the basis stage gave no basis"),
    }
}

/// One plain solve with J's factor (the same ordering as the run's), the yardstick of a step
/// (ms): repeated, and after a cache flush; by the subtree-parallel sweeps a step uses, then
/// by faer's sequential ones.
struct SolveTimes {
    repeated_ms: f64,
    flushed_ms: f64,
    sequential_repeated_ms: f64,
    sequential_flushed_ms: f64,
}

fn plain_solve_ms(structure: &Structure, theta: f64, tau: f64) -> SolveTimes {
    let cholesky = factorise_J(structure, theta, tau).expect("J is positive definite");
    let n = structure.K.n_rows;
    let mut rhs: Vec<f64> = (0..n).map(|i| ((i * 7919) % 1000) as f64 - 500.0).collect();
    // Within a step the factor meets a cold cache: the step's other work (the products, W)
    // streams more than the last-level cache between two sweeps. The same solve after a
    // 64 MiB flush is the like-for-like reference.
    let flush: Vec<f64> = (0..8 << 20).map(|i| i as f64).collect();
    let repeats = 20;
    let mut time = |flushed: bool, solve: &mut dyn FnMut(&mut [f64])| {
        let mut seconds = 0.0;
        let mut checksum = 0.0;
        for _ in 0..repeats {
            if flushed {
                checksum += flush.iter().sum::<f64>();
            }
            let clock = Instant::now();
            solve(&mut rhs);
            seconds += clock.elapsed().as_secs_f64();
        }
        std::hint::black_box(checksum);
        1e3 * seconds / repeats as f64
    };
    let mut subtree = |x: &mut [f64]| cholesky.solve_vector(x);
    let (repeated_ms, flushed_ms) = (time(false, &mut subtree), time(true, &mut subtree));
    let mut sequential = |x: &mut [f64]| {
        cholesky.solve_in_place(MatMut::from_column_major_slice_mut(x, n, 1), Par::Seq)
    };
    SolveTimes {
        repeated_ms,
        flushed_ms,
        sequential_repeated_ms: time(false, &mut sequential),
        sequential_flushed_ms: time(true, &mut sequential),
    }
}

/// The scheme's data for `transient_scipy.py`.
fn export(
    dir: &str,
    structure: &Structure,
    contact_state: &squeal_stages::transient::scheme::ContactState,
    v0: &[f64],
) {
    let dir = std::path::Path::new(dir);
    std::fs::create_dir_all(dir).expect("export directory");
    for (name, matrix) in [("M", structure.M), ("C", structure.C), ("K", structure.K)] {
        let text = write_matrix_market(matrix, name).expect("a finite matrix");
        std::fs::write(dir.join(format!("{name}.mtx")), text).expect("write matrix");
    }
    let mut h = std::fs::File::create(dir.join("H.csv")).expect("H.csv");
    writeln!(h, "row,dof,value").unwrap();
    for (row, entries) in structure.H_rows.iter().enumerate() {
        for (dof, value) in entries {
            writeln!(h, "{row},{dof},{value:e}").unwrap();
        }
    }
    let mut pairs = std::fs::File::create(dir.join("pairs.csv")).expect("pairs.csv");
    writeln!(pairs, "gap,sliding_speed,r_n,r_t,r_b,mu").unwrap();
    for p in 0..contact_state.gap.len() {
        writeln!(
            pairs,
            "{:e},{:e},{:e},{:e},{:e},{:e}",
            contact_state.gap[p],
            contact_state.sliding_speed[p],
            contact_state.r_e[3 * p],
            contact_state.r_e[3 * p + 1],
            contact_state.r_e[3 * p + 2],
            contact_state.mu[p]
        )
        .unwrap();
    }
    let text: String = v0.iter().map(|value| format!("{value:e}\n")).collect();
    std::fs::write(dir.join("v0.csv"), text).expect("v0.csv");
    println!("exported to {}", dir.display());
}

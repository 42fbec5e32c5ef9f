//! Every complex mode below 17 kHz of the default brake (`mesh.brake` defaults, μ = 0.38,
//! ω = 4 rad/s, interference 0.1 mm): wall time, shifts, counts, worst residual and peak memory
//! of `method: krylov`, then `real_mode_projection` and its error against it.
//! Run with `cargo bench -p squeal-stages --bench stability`. `SQUEAL_BENCH_F_MAX_HZ`,
//! `SQUEAL_BENCH_MAX_DIVERGENCE_RATE`, `SQUEAL_BENCH_BLOCK`, `SQUEAL_BENCH_MAX_BASIS`,
//! `SQUEAL_BENCH_PER_SHIFT` and `SQUEAL_BENCH_ARNOLDI_TOLERANCE` override the settings;
//! `SQUEAL_BENCH_PROJECTION=0` skips the projection; `SQUEAL_LOG=debug` shows each shift's
//! convergence. `SQUEAL_BENCH_SOLVE=1` times one block solve of the Krylov operator instead, by
//! the row-major kernels and by faer's (`stability::lblt`), and the operator's M̃/C̃ product.
//!
//! With `SQUEAL_EXPORT_DIR=<dir>` the reduced matrices M̃, C̃, K̃ (Matrix Market) and the
//! eigenvalues found (`eigenvalues.csv`) are written there for `scipy_eigs.py`, which times
//! scipy's shift-invert `eigs` on the same problem.

use std::f64::consts::PI;
use std::io::IsTerminal;
use std::time::Instant;

use faer::sparse::linalg::cholesky::SymbolicCholesky;
use faer::{Mat, MatMut, Par, c64};
use squeal_linalg::lblt::Lblt;
use squeal_linalg::matrix_market::write_matrix_market;
use squeal_stages::artifact::Equilibrium;
use squeal_stages::artifact::Model;
use squeal_stages::assemble::with_default_materials;
use squeal_stages::contact::lcp::LcpSettings;
use squeal_stages::equilibrium::{Load, Solver, solve as equilibrium};
use squeal_stages::mesh::brake::{BrakeGeometry, brake};
use squeal_stages::stability::shift_invert::EmbeddedPattern;
use squeal_stages::stability::sliding::{Part, SlidingSystem};
use squeal_stages::stability::{
    KrylovOptions, Method, Settings, Solution, divergence_rate, is_unstable,
    nearest_relative_errors, solve,
};

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

/// An override from the environment (`SQUEAL_BENCH_<NAME>`), for exploring the tuning.
fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(format!("SQUEAL_BENCH_{name}"))
        .ok()
        .and_then(|value| value.parse().ok())
        .unwrap_or(default)
}

/// One block solve of eight right-hand sides with the symmetric part's factor at 8 kHz, as the
/// Krylov operator makes it (the row-major kernels share the tree among threads, faer's the
/// columns, four per thread).
fn solve_kernels(model: &Model, equilibrium: &Equilibrium) {
    let system = SlidingSystem::new(model, equilibrium, true).expect("sliding system");
    let pattern = EmbeddedPattern::new(&system).expect("symbolic analysis");
    let values = pattern.values_at(c64::new(0.0, 2.0 * PI * 8000.0));
    let symbolic = pattern.symbolic();
    let factor = Lblt::factorize(symbolic, pattern.matrix(&values), Par::rayon(0));
    let rhs = Mat::<f64>::from_fn(2 * system.dim(), 8, |i, j| {
        ((i * 7 + j * 13) % 17) as f64 - 8.0
    });
    let by_columns = |solve: Solve| {
        let half = |first: usize| {
            let mut solution = rhs.subcols(first, 4).to_owned();
            solve(&factor, symbolic, solution.as_mut());
            solution
        };
        let (left, right) = rayon::join(|| half(0), || half(4));
        Mat::from_fn(rhs.nrows(), 8, |i, j| {
            if j < 4 {
                left[(i, j)]
            } else {
                right[(i, j - 4)]
            }
        })
    };
    let row_major = || {
        let mut solution = rhs.clone();
        factor.solve_in_place(symbolic, solution.as_mut());
        solution
    };
    let row_major_by_columns = || by_columns(Lblt::solve_in_place_one_thread);
    let faer = || by_columns(Lblt::solve_in_place_faer);
    let kernels: [(&str, &dyn Fn() -> Mat<f64>); 3] = [
        ("row-major", &row_major),
        ("row-major, columns shared out", &row_major_by_columns),
        ("faer", &faer),
    ];
    let mut solutions = Vec::new();
    for (name, block) in kernels {
        solutions.push(block());
        let ms = milliseconds_per_run(10, block);
        println!(
            "{name}: {ms:.1} ms per block of eight ({:.2} ms per right-hand side)",
            ms / 8.0
        );
    }
    let difference = (&solutions[0] - &solutions[2]).norm_max() / solutions[2].norm_max();
    println!(
        "{} factor entries, tree shared among threads: {}; the two solutions differ by {difference:.1e} (relative)",
        pattern.factor_len(),
        factor.splits_tree()
    );
    products(&system);
}

/// The operator's `M̃ X + C̃ Y` for a block of eight: one pass over the paired rows, against
/// the two matrices' products taken apart.
fn products(system: &SlidingSystem) {
    let block = |seed: usize| {
        Mat::<c64>::from_fn(system.dim(), 8, |i, j| {
            let t = (i * 7 + j * 13 + seed) as f64;
            c64::new(t.sin(), (0.3 * t).cos())
        })
    };
    let (x, y) = (block(1), block(2));
    let paired = || system.apply_mass_damping(x.as_ref(), y.as_ref());
    let apart =
        || system.apply_block(Part::M, x.as_ref()) + system.apply_block(Part::C, y.as_ref());
    let products: [(&str, &dyn Fn() -> Mat<c64>); 2] =
        [("M̃ X + C̃ Y paired", &paired), ("M̃ X + C̃ Y apart", &apart)];
    let mut results = Vec::new();
    for (name, product) in products {
        results.push(product());
        let ms = milliseconds_per_run(20, product);
        println!("{name}: {ms:.1} ms per block of eight");
    }
    let difference = (&results[0] - &results[1]).norm_max() / results[1].norm_max();
    println!("the two products differ by {difference:.1e} (relative)");
}

/// Mean wall time of `run` over `repetitions` runs (ms).
fn milliseconds_per_run<T>(repetitions: usize, run: &dyn Fn() -> T) -> f64 {
    let started = Instant::now();
    for _ in 0..repetitions {
        run();
    }
    1e3 * started.elapsed().as_secs_f64() / repetitions as f64
}

type Solve = fn(&Lblt, &SymbolicCholesky<usize>, MatMut<'_, f64>);

fn main() {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_env("SQUEAL_LOG")
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .init();
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
    println!(
        "default brake: {} free DOFs, {} closed pairs of {}",
        model.n_dofs(),
        equilibrium.closed.iter().filter(|closed| **closed).count(),
        equilibrium.closed.len()
    );
    if env_or("SOLVE", 0) == 1 {
        solve_kernels(&model, &equilibrium);
        return;
    }

    let defaults = Settings::default();
    let settings = Settings {
        f_max_hz: env_or("F_MAX_HZ", defaults.f_max_hz),
        max_divergence_rate: env_or("MAX_DIVERGENCE_RATE", defaults.max_divergence_rate),
        krylov: KrylovOptions {
            block_size: env_or("BLOCK", defaults.krylov.block_size),
            basis: env_or("BASIS", defaults.krylov.basis),
            max_basis: env_or("MAX_BASIS", defaults.krylov.max_basis),
            per_shift: env_or("PER_SHIFT", defaults.krylov.per_shift),
            arnoldi_tolerance: env_or("ARNOLDI_TOLERANCE", defaults.krylov.arnoldi_tolerance),
            ..defaults.krylov
        },
        ..defaults
    };
    let started = Instant::now();
    let solution = solve(&model, &equilibrium, &settings).expect("krylov");
    let seconds = started.elapsed().as_secs_f64();
    print_band(&solution, &settings, seconds);
    if env_or("PROJECTION", 1) != 0 {
        compare_projection(&model, &equilibrium, &solution, &settings);
    }
    if let Ok(dir) = std::env::var("SQUEAL_EXPORT_DIR") {
        export(&solution, std::path::Path::new(&dir));
    }
}

/// The band's figures: wall time and its parts, each shift, the unstable modes.
fn print_band(solution: &Solution, settings: &Settings, seconds: f64) {
    let report = &solution.report;
    let worst = solution
        .pairs
        .iter()
        .map(|pair| pair.residual)
        .fold(0.0, f64::max);
    println!(
        "krylov: {:.1} s wall ({:.1} s factorisations and contact corrections, {:.1} s Arnoldi), peak memory {:.0} MiB",
        seconds,
        report.band.seconds_factor,
        report.band.seconds_arnoldi,
        peak_memory_mib()
    );
    println!(
        "  {} eigenvalues below {} Hz (the μ = 0 undamped structure has {}), worst residual {worst:.1e}, factor entries {}",
        solution.pairs.len(),
        settings.f_max_hz,
        report.conservative_count,
        report.band.factor_entries
    );
    println!(
        "  {} shifts, {} of them fell short at the basis limit and were kept",
        report.band.shifts.len(),
        report.band.fell_short
    );
    for shift in &report.band.shifts {
        let seconds = &shift.seconds;
        println!(
            "  shift {:>8.0} Hz: basis {:>4}, trusted radius {:>7.0} Hz, {:>4} converged, {:>4} kept, {:>3} matched in the overlap",
            shift.frequency_hz,
            shift.basis,
            shift.radius / (2.0 * PI),
            shift.found,
            shift.kept,
            shift.overlap_matched
        );
        println!(
            "      {:.1} s factor, {:.1} s operator, {:.1} s orthogonalisation, {:.1} s Ritz, {:.1} s vectors",
            seconds.factor,
            seconds.operator,
            seconds.orthogonalisation,
            seconds.ritz,
            seconds.vectors
        );
    }
    let unstable: Vec<_> = solution
        .pairs
        .iter()
        .filter(|pair| is_unstable(pair.lambda))
        .collect();
    println!("  {} unstable modes:", unstable.len());
    for pair in &unstable {
        println!(
            "    {:>9.1} Hz  divergence rate {:>8.4} %",
            pair.lambda.im / (2.0 * PI),
            100.0 * divergence_rate(pair.lambda)
        );
    }
}

/// The real-mode projection's run time and its eigenvalue errors against `solution`.
fn compare_projection(
    model: &Model,
    equilibrium: &Equilibrium,
    solution: &Solution,
    settings: &Settings,
) {
    let started = Instant::now();
    let projected = solve(
        model,
        equilibrium,
        &Settings {
            method: Method::RealModeProjection { n_real_modes: 0 },
            ..*settings
        },
    )
    .expect("projection");
    let projection_seconds = started.elapsed().as_secs_f64();
    let mut sorted = nearest_relative_errors(&solution.pairs, &projected.pairs);
    sorted.sort_by(f64::total_cmp);
    println!(
        "real_mode_projection: {:.1} s with {} real modes; eigenvalue error against krylov: median {:.1e}, max {:.1e}; {} unstable",
        projection_seconds,
        projected.report.real_modes,
        sorted.get(sorted.len() / 2).copied().unwrap_or(f64::NAN),
        sorted.last().copied().unwrap_or(f64::NAN),
        projected
            .pairs
            .iter()
            .filter(|pair| is_unstable(pair.lambda))
            .count()
    );
}

/// M, C, K of the reduced sliding problem (Matrix Market), the eigenvalues and the shifts
/// (CSV), for the scipy comparison.
fn export(solution: &Solution, dir: &std::path::Path) {
    std::fs::create_dir_all(dir).expect("export folder");
    for (name, part) in [("M", Part::M), ("C", Part::C), ("K", Part::K)] {
        let matrix = solution.system.reduced_matrix(part);
        let text = write_matrix_market(&matrix, "squeal stability: reduced sliding problem")
            .expect("matrix market");
        std::fs::write(dir.join(format!("{name}.mtx")), text).expect("write");
    }
    let mut csv = String::from("re,im,residual\n");
    for pair in &solution.pairs {
        csv.push_str(&format!(
            "{:.17e},{:.17e},{:.3e}\n",
            pair.lambda.re, pair.lambda.im, pair.residual
        ));
    }
    std::fs::write(dir.join("eigenvalues.csv"), csv).expect("write");
    let mut shifts = String::from("frequency_hz,radius,converged\n");
    for shift in &solution.report.band.shifts {
        shifts.push_str(&format!(
            "{},{},{}\n",
            shift.frequency_hz, shift.radius, shift.found
        ));
    }
    std::fs::write(dir.join("shifts.csv"), shifts).expect("write");
    println!(
        "exported M.mtx, C.mtx, K.mtx, eigenvalues.csv and shifts.csv to {}",
        dir.display()
    );
}

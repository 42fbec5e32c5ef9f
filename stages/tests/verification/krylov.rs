//! The complex eigenvalues of the sliding brake (`stability`'s Krylov band search) against a
//! dense quadratic eigensolve, with several block sizes and with disks that fall short; and,
//! without friction nor damping, against the real modes of the symmetric problem.

use faer::c64;
use serde::Deserialize;
use squeal_linalg::eigensolver::{self, Band, SolveOptions};
use squeal_stages::artifact::Equilibrium;
use squeal_stages::artifact::Model;
use squeal_stages::assemble::with_default_materials;
use squeal_stages::contact::lcp::LcpSettings;
use squeal_stages::equilibrium::{self, Load, Solver};
use squeal_stages::mesh::brake::{BrakeGeometry, brake};
use squeal_stages::stability::sliding::SlidingSystem;
use squeal_stages::stability::{KrylovOptions, Settings, dense, in_band, is_unstable, solve};

use crate::reference;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AgainstDense {
    mu: f64,
    f_max_hz: f64,
    max_divergence_rate: f64,
    /// Krylov blocks tried: (block size, 0 for the default; eigenvalues per shift; largest
    /// basis).
    krylov: Vec<[usize; 3]>,
    /// |λ − λ_dense| / |λ_dense| of the worst eigenvalue.
    eigenvalue_tolerance: f64,
    residual_tolerance: f64,
    least_eigenvalues: usize,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AgainstRealModes {
    f_max_hz: f64,
    per_shift: usize,
    /// |λ − i ω_real| / ω_real of the worst eigenvalue.
    eigenvalue_tolerance: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct StiffnessContrast {
    mu: f64,
    f_max_hz: f64,
    pad_moduli: Vec<f64>,
    eigenvalue_tolerance: f64,
    residual_tolerance: f64,
}

/// The sliding equilibrium of `model` at friction `mu` (ω = 4 rad/s, 50 µm interference).
fn equilibrium_of(model: &Model, mu: f64) -> Equilibrium {
    equilibrium::solve(
        model,
        mu,
        4.0,
        Load::Interference(5e-5),
        Solver::SemismoothNewton,
        &LcpSettings::default(),
    )
    .expect("sliding equilibrium")
    .0
}

/// Every eigenvalue in the band of `settings` by the dense quadratic eigensolve, and the
/// problem's size.
fn dense_reference(
    model: &Model,
    equilibrium: &Equilibrium,
    settings: &Settings,
) -> (Vec<c64>, usize) {
    let system =
        SlidingSystem::new(model, equilibrium, settings.friction_damping).expect("sliding system");
    let [M, C, K] = dense::dense_matrices(&system);
    let eigenvalues = dense::quadratic_eigen(M.as_ref(), C.as_ref(), K.as_ref(), |lambda| {
        in_band(lambda, settings)
    })
    .expect("dense quadratic eigensolve")
    .into_iter()
    .map(|(lambda, _)| lambda)
    .collect();
    (eigenvalues, system.dim())
}

/// The worst relative distance from each of `found` to its own nearest of `reference`, with
/// the same number of eigenvalues in both.
fn worst_difference(found: &[c64], reference: &[c64]) -> f64 {
    assert_eq!(
        found.len(),
        reference.len(),
        "found {} eigenvalues, the reference has {}",
        found.len(),
        reference.len()
    );
    let mut used = vec![false; reference.len()];
    let mut worst: f64 = 0.0;
    for lambda in found {
        let (index, distance) = reference
            .iter()
            .enumerate()
            .filter(|(index, _)| !used[*index])
            .map(|(index, other)| (index, (other - lambda).norm() / other.norm()))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("an unused reference eigenvalue");
        used[index] = true;
        worst = worst.max(distance);
    }
    worst
}

#[test]
fn krylov_finds_every_eigenvalue_of_the_dense_solve_on_a_coarse_brake() {
    let case: AgainstDense = reference::load("krylov_against_dense");
    // About 1,300 DOFs: the dense reference (a 2,600 × 2,600 eigenproblem) takes seconds.
    let mesh = brake(&BrakeGeometry {
        n_radial: 3,
        n_theta: 36,
        n_thick: 2,
        pucks_radial: 1,
        pucks_angular: 2,
        puck_cells: 2,
        puck_layers: 2,
        ..BrakeGeometry::coarse()
    })
    .expect("mesh");
    let (model, _) = with_default_materials(&mesh, "hub, pad_backs", &[]).expect("assembly");
    let equilibrium = equilibrium_of(&model, case.mu);
    let settings = Settings {
        f_max_hz: case.f_max_hz,
        max_divergence_rate: case.max_divergence_rate,
        dense_limit: 0,
        ..Settings::default()
    };
    let (reference, dim) = dense_reference(&model, &equilibrium, &settings);
    // The default block, and a small and a large one: a disk's radius must not be trusted
    // before the Krylov space has resolved it, whatever the block. Small disks, so that the
    // band needs several shifts and their overlaps are checked. Last, disks aimed far beyond
    // what the basis allows: shifts fall short and gaps are filled below them.
    let default_block = KrylovOptions::default().block_size;
    let full_basis = case.krylov.iter().map(|k| k[2]).max().unwrap_or(0);
    for &[block_size, per_shift, max_basis] in &case.krylov {
        let block_size = if block_size == 0 {
            default_block
        } else {
            block_size
        };
        let settings = Settings {
            krylov: KrylovOptions {
                block_size,
                per_shift,
                max_basis,
                ..KrylovOptions::default()
            },
            ..settings
        };
        let solution = solve(&model, &equilibrium, &settings).expect("stability");
        let fell_short = solution.report.band.fell_short;
        assert_eq!(
            fell_short > 0,
            max_basis < full_basis,
            "{fell_short} shifts fell short with a basis of up to {max_basis}"
        );
        assert!(
            solution.report.band.shifts.len() >= 3,
            "{:?}",
            solution.report.band.shifts
        );
        let found: Vec<c64> = solution.pairs.iter().map(|pair| pair.lambda).collect();
        let worst = worst_difference(&found, &reference);
        assert!(
            worst <= case.eigenvalue_tolerance,
            "blocks of {block_size}, up to {max_basis} vectors: worst relative difference {worst:e}"
        );
        assert!(
            found.len() >= case.least_eigenvalues,
            "{} eigenvalues only",
            found.len()
        );
        for pair in &solution.pairs {
            assert!(
                pair.residual <= case.residual_tolerance,
                "{}",
                pair.residual
            );
        }
        eprintln!(
            "blocks of {block_size}, up to {max_basis} vectors: {} DOFs, {} eigenvalues below {} Hz, {} unstable, {} shifts ({fell_short} fell short), worst difference {worst:.1e}",
            dim,
            found.len(),
            settings.f_max_hz,
            found.iter().filter(|lambda| is_unstable(**lambda)).count(),
            solution.report.band.shifts.len()
        );
    }
}

#[test]
fn without_friction_no_mode_is_unstable_and_the_frequencies_are_the_real_modes() {
    let case: AgainstRealModes = reference::load("krylov_against_real_modes");
    let mesh = brake(&BrakeGeometry::small()).expect("mesh");
    let undamped = [
        ("alpha_disc", 0.0),
        ("beta_disc", 0.0),
        ("alpha_pad", 0.0),
        ("beta_pad", 0.0),
    ];
    let (model, _) = with_default_materials(&mesh, "hub, pad_backs", &undamped).expect("assembly");
    let equilibrium = equilibrium_of(&model, 0.0);
    let settings = Settings {
        f_max_hz: case.f_max_hz,
        dense_limit: 0,
        krylov: KrylovOptions {
            per_shift: case.per_shift,
            ..KrylovOptions::default()
        },
        ..Settings::default()
    };
    let solution = solve(&model, &equilibrium, &settings).expect("stability");
    let system = &solution.system;
    let omega_max = 2.0 * std::f64::consts::PI * settings.f_max_hz;
    let real = eigensolver::solve(
        &system.K_sym,
        &system.M_sym,
        &system.dof_of_node,
        Band {
            n_modes: 0,
            lambda_lo: 0.0,
            lambda_hi: omega_max * omega_max,
        },
        SolveOptions::default(),
    )
    .expect("real modes");
    let expected: Vec<c64> = real
        .lambda
        .iter()
        .map(|lambda| c64::new(0.0, lambda.sqrt()))
        .collect();
    let found: Vec<c64> = solution.pairs.iter().map(|pair| pair.lambda).collect();
    let worst = worst_difference(&found, &expected);
    assert!(worst <= case.eigenvalue_tolerance, "{worst:e}");
    assert!(found.iter().all(|lambda| !is_unstable(*lambda)));
    assert_eq!(solution.report.conservative_count, found.len());

    // With the default Rayleigh damping, still nothing unstable at μ = 0.
    let (damped_model, _) = with_default_materials(&mesh, "hub, pad_backs", &[]).expect("assembly");
    let damped = solve(
        &damped_model,
        &equilibrium_of(&damped_model, 0.0),
        &settings,
    )
    .expect("stability");
    assert!(damped.pairs.iter().all(|pair| pair.lambda.re < 0.0));
}

#[test]
fn pads_a_million_times_softer_or_stiffer_than_the_disc_keep_krylov_on_the_dense_solve() {
    let case: StiffnessContrast = reference::load("krylov_stiffness_contrast");
    let mesh = brake(&BrakeGeometry::small()).expect("mesh");
    for &modulus in &case.pad_moduli {
        let (model, _) = with_default_materials(&mesh, "hub, pad_backs", &[("E_pad", modulus)])
            .expect("assembly");
        let equilibrium = equilibrium_of(&model, case.mu);
        let settings = Settings {
            f_max_hz: case.f_max_hz,
            dense_limit: 0,
            ..Settings::default()
        };
        let (reference, _) = dense_reference(&model, &equilibrium, &settings);
        let solution = solve(&model, &equilibrium, &settings)
            .unwrap_or_else(|err| panic!("E_pad = {modulus:e} Pa: {err}"));
        let found: Vec<c64> = solution.pairs.iter().map(|pair| pair.lambda).collect();
        let worst = worst_difference(&found, &reference);
        let residual = solution
            .pairs
            .iter()
            .map(|pair| pair.residual)
            .fold(0.0, f64::max);
        eprintln!(
            "E_pad = {modulus:e} Pa: {} eigenvalues, {} unstable, worst difference {worst:.1e}, worst residual {residual:.1e}",
            found.len(),
            found.iter().filter(|lambda| is_unstable(**lambda)).count()
        );
        assert!(!found.is_empty());
        assert!(
            worst <= case.eigenvalue_tolerance,
            "E_pad = {modulus:e} Pa: {worst:e}"
        );
        assert!(
            residual <= case.residual_tolerance,
            "E_pad = {modulus:e} Pa: {residual:e}"
        );
    }
}

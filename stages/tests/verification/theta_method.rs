//! The θ-method with contact impulses (`transient` stage's scheme) on small models with exact
//! solutions: energy conservation and the modal response with its order of convergence, a
//! mass dropped on a plane, and a million steps of the stick–slip oscillator. (The stick–slip
//! oscillator's closed form and Hoffmann's model growing into a limit cycle run through
//! `transient.matrices`, in `lumped_transient.rs`; the brake's growth rate against its most
//! unstable mode shares the stage tests' fixture and stays in `transient/tests.rs`.)

use std::f64::consts::PI;

use faer::{Mat, Side};
use serde::Deserialize;
use squeal_stages::NoCheckpoints;
use squeal_stages::artifact::CscMatrix;
use squeal_stages::transient::contact::{Solver, pad_blocks};
use squeal_stages::transient::scheme::{
    self, ContactState, Load, Settings, SolveBy, Structure, integrate,
};

use crate::reference;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Chain {
    /// θ = ½, no damping, no contact: a run of `energy_duration` s at `energy_tau`.
    energy_tau: f64,
    energy_duration: f64,
    /// Kinetic + strain energy and the balance error against the initial energy, relative.
    energy_tolerance: f64,
    /// The response at `order_duration` against the exact modal solution, for each step of
    /// `order_taus`, and the fitted order for each [θ, expected order].
    order_duration: f64,
    order_taus: Vec<f64>,
    orders: Vec<[f64; 2]>,
    order_tolerance: f64,
    /// Error of θ = ½ at the finest step.
    finest_error: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Drop {
    mass: f64,
    gap: f64,
    fall_speed: f64,
    sliding_speed: f64,
    mu: f64,
    tau: f64,
    n_steps: usize,
    thetas: Vec<f64>,
    /// Penetration, rebound velocity, final velocity and energies (m, m/s, J): round-off.
    tolerance: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct StickSlip {
    mass: f64,
    stiffness: f64,
    normal_force: f64,
    mu: f64,
    belt_speed: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Stress {
    /// The four springs of the stiff chain, wall to wall.
    springs: [f64; 4],
    taus: Vec<f64>,
    thetas: Vec<f64>,
    n_steps: usize,
    /// Energy growth (any θ), energy change (θ = ½) and balance error, relative to the start.
    energy_tolerance: f64,
    /// The stick–slip oscillator's long run.
    long_run_steps: usize,
    long_run_balance_tolerance: f64,
    long_run_amplitude_tolerance: f64,
}

fn settings(theta: f64, tau: f64, n_steps: usize) -> Settings {
    Settings {
        theta,
        tau,
        n_steps,
        solver: Solver::ActiveSet,
        tolerance: 1e-12,
        max_iterations: 5000,
        output_every: 1,
        record_pairs: Vec::new(),
        record_dofs: Vec::new(),
        record_contacts: false,
        snapshot_steps: Vec::new(),
        sample_steps: Vec::new(),
        solve_by: SolveBy::Choice,
    }
}

fn no_contact() -> ContactState {
    ContactState {
        gap: Vec::new(),
        sliding_speed: Vec::new(),
        r_e: Vec::new(),
        mu: Vec::new(),
        mu_static: Vec::new(),
        speed_scale: 0.0,
        blocks: Vec::new(),
    }
}

/// A chain of three unit masses between two walls, springs 1, 2, 3, 4 (ω from 1 to 2.6 rad/s).
fn chain() -> (CscMatrix, CscMatrix, CscMatrix) {
    chain_of([1.0, 2.0, 3.0, 4.0])
}

/// Three unit masses between two walls on `springs`, wall to wall.
fn chain_of(springs: [f64; 4]) -> (CscMatrix, CscMatrix, CscMatrix) {
    let mut K = Vec::new();
    for i in 0..3 {
        K.push((i, i, springs[i] + springs[i + 1]));
        if i + 1 < 3 {
            K.push((i, i + 1, -springs[i + 1]));
            K.push((i + 1, i, -springs[i + 1]));
        }
    }
    let M = CscMatrix::from_triplets(3, 3, (0..3).map(|i| (i, i, 1.0)).collect());
    let C = CscMatrix::from_triplets(3, 3, Vec::new());
    (M, CscMatrix::from_triplets(3, 3, K), C)
}

/// The exact free response of `ü + K u = 0` (M = I) at time t.
fn exact_chain(K: &CscMatrix, u0: &[f64], v0: &[f64], t: f64) -> Vec<f64> {
    let dense = Mat::from_fn(3, 3, |i, j| {
        K.triplets()
            .filter(|&(r, c, _)| r == i && c == j)
            .map(|(_, _, v)| v)
            .sum::<f64>()
    });
    let eigen = dense.self_adjoint_eigen(Side::Lower).unwrap();
    let (values, vectors) = (eigen.S(), eigen.U());
    let mut u = vec![0.0; 3];
    for k in 0..3 {
        let omega = values[k].sqrt();
        let phi: Vec<f64> = (0..3).map(|i| vectors[(i, k)]).collect();
        let a: f64 = (0..3).map(|i| phi[i] * u0[i]).sum();
        let b: f64 = (0..3).map(|i| phi[i] * v0[i]).sum();
        let q = a * (omega * t).cos() + b / omega * (omega * t).sin();
        for i in 0..3 {
            u[i] += phi[i] * q;
        }
    }
    u
}

fn run_chain(theta: f64, tau: f64, duration: f64) -> (Vec<f64>, scheme::Run) {
    let (M, K, C) = chain();
    let structure = Structure {
        M: &M,
        C: &C,
        K: &K,
        dof_of_node: &[],
        H_rows: Vec::new(),
        load: Load::default(),
    };
    let n_steps = (duration / tau).round() as usize;
    let mut settings = settings(theta, tau, n_steps);
    settings.snapshot_steps = vec![n_steps];
    let run = integrate(
        &structure,
        &no_contact(),
        &settings,
        vec![1.0, 0.0, -0.5],
        vec![0.0, 0.3, 0.0],
        &NoCheckpoints,
        |_| {},
    )
    .unwrap();
    (run.snapshots[0].u.clone(), run)
}

#[test]
fn undamped_scheme_without_contact_conserves_energy_exactly() {
    let case: Chain = reference::load("theta_method_chain");
    let (_, run) = run_chain(0.5, case.energy_tau, case.energy_duration);
    assert_eq!(run.history.len(), 10_001);
    let initial = run.history[0].energy.kinetic + run.history[0].energy.strain;
    for row in &run.history {
        let total = row.energy.kinetic + row.energy.strain;
        assert!(
            (total - initial).abs() < case.energy_tolerance * initial,
            "t = {}: {total} vs {initial}",
            row.t
        );
        assert!(row.energy.balance_error.abs() < case.energy_tolerance * initial);
        assert_eq!(row.energy.scheme, 0.0);
    }
}

#[test]
fn the_response_converges_to_the_exact_modal_solution_at_the_scheme_order() {
    let case: Chain = reference::load("theta_method_chain");
    let (_, K, _) = chain();
    let duration = case.order_duration;
    let exact = exact_chain(&K, &[1.0, 0.0, -0.5], &[0.0, 0.3, 0.0], duration);
    for &[theta, expected_order] in &case.orders {
        let errors: Vec<(f64, f64)> = case
            .order_taus
            .iter()
            .map(|&tau| {
                let (u, _) = run_chain(theta, tau, duration);
                let error = u
                    .iter()
                    .zip(&exact)
                    .map(|(a, b)| (a - b).powi(2))
                    .sum::<f64>()
                    .sqrt();
                (tau, error)
            })
            .collect();
        let slope = crate::fit::log_log_slope(&errors);
        assert!(
            (slope - expected_order).abs() < case.order_tolerance,
            "theta = {theta}: order {slope}, errors {errors:?}"
        );
        if theta == 0.5 {
            assert!(errors[3].1 < case.finest_error, "{errors:?}");
        }
    }
}

/// `M`, `K`, `C` and the rows of `H`.
type LumpedStructure = (CscMatrix, CscMatrix, CscMatrix, Vec<Vec<(usize, f64)>>);

/// One pad node (3 DOFs, mass `m`) over a rigid plane z = 0 whose material slides at `speed`
/// along y; frame n = e_z, t = e_y, b = n × t = −e_x.
fn point_on_plane(m: f64, stiffness: [f64; 3]) -> LumpedStructure {
    let M = CscMatrix::from_triplets(3, 3, (0..3).map(|i| (i, i, m)).collect());
    let K = CscMatrix::from_triplets(3, 3, (0..3).map(|i| (i, i, stiffness[i])).collect());
    let C = CscMatrix::from_triplets(3, 3, Vec::new());
    let H_rows = vec![vec![(2, 1.0)], vec![(1, 1.0)], vec![(0, -1.0)]];
    (M, K, C, H_rows)
}

#[test]
fn a_mass_dropped_on_a_plane_stops_on_it_without_penetrating() {
    let case: Drop = reference::load("mass_dropped_on_a_plane");
    let (M, K, C, H_rows) = point_on_plane(case.mass, [0.0; 3]);
    let structure = Structure {
        M: &M,
        C: &C,
        K: &K,
        dof_of_node: &[],
        H_rows,
        load: Load::default(),
    };
    let gap = case.gap;
    let contact_state = ContactState {
        gap: vec![gap],
        sliding_speed: vec![case.sliding_speed],
        r_e: vec![0.0; 3],
        mu: vec![case.mu],
        mu_static: vec![case.mu],
        speed_scale: 0.0,
        blocks: pad_blocks(&[0]),
    };
    let tolerance = case.tolerance;
    for &theta in &case.thetas {
        let tau = case.tau;
        let mut settings = settings(theta, tau, case.n_steps);
        settings.record_pairs = vec![0];
        let run = integrate(
            &structure,
            &contact_state,
            &settings,
            vec![0.0; 3],
            vec![0.0, 0.0, -case.fall_speed],
            &NoCheckpoints,
            |_| {},
        )
        .unwrap();
        let impact = run
            .history
            .iter()
            .position(|row| gap + row.points[0].0 <= tolerance)
            .expect("the mass reaches the plane");
        for row in &run.history {
            let (displacement, velocity) = row.points[0];
            assert!(
                gap + displacement >= -tolerance,
                "theta = {theta}: penetration {}",
                -(gap + displacement)
            );
            if row.t > run.history[impact].t + 1.5 * tau {
                // Inelastic: at rest on the plane from the step after contact on.
                assert!(
                    velocity.abs() < tolerance,
                    "theta = {theta}, t = {}: v_n = {velocity}",
                    row.t
                );
            }
        }
        assert!(run.peak_penetration <= tolerance);
        // The normal kinetic energy ½ m v² is lost in the impact, and the friction impulse,
        // μ times the normal one, drags the mass to μ v along the sliding disc (slower than
        // the disc: it slides throughout).
        let last = run.history.last().unwrap();
        let dragged = case.mu * case.fall_speed;
        assert!(dragged < case.sliding_speed);
        assert!(
            (last.v_t - dragged).abs() < tolerance,
            "theta = {theta}: {last:?}"
        );
        assert!(
            (last.energy.kinetic - 0.5 * case.mass * dragged * dragged).abs() < tolerance,
            "{last:?}"
        );
        // θ = ½ books the whole loss to the impact; θ > ½ shares it with its own
        // dissipation (the balance holds either way).
        if theta == 0.5 {
            let impact_loss = 0.5 * case.mass * case.fall_speed * case.fall_speed;
            assert!(
                (last.energy.normal + impact_loss).abs() < tolerance,
                "{last:?}"
            );
            assert_eq!(last.energy.scheme, 0.0);
        } else {
            assert!(last.energy.scheme > 0.0, "{last:?}");
        }
        assert!(last.energy.balance_error.abs() < tolerance, "{last:?}");
    }
}

/// The stick–slip oscillator of `case` from rest at x = 0, θ = ½ at 2,000 steps a period, for
/// `n_steps`, a history row every `output_every` steps and snapshots from `first_snapshot`;
/// and its sliding equilibrium x_e = μN/k.
fn stick_slip(
    case: &StickSlip,
    n_steps: usize,
    output_every: usize,
    first_snapshot: usize,
) -> (scheme::Run, f64) {
    let (m, k, normal_force, mu, belt) = (
        case.mass,
        case.stiffness,
        case.normal_force,
        case.mu,
        case.belt_speed,
    );
    let (M, K, C, H_rows) = point_on_plane(m, [k, k, 1e4]);
    let structure = Structure {
        M: &M,
        C: &C,
        K: &K,
        dof_of_node: &[],
        H_rows,
        load: Load::default(),
    };
    let contact_state = ContactState {
        gap: vec![0.0],
        sliding_speed: vec![belt],
        r_e: vec![normal_force, mu * normal_force, 0.0],
        mu: vec![mu],
        mu_static: vec![mu],
        speed_scale: 0.0,
        blocks: pad_blocks(&[0]),
    };
    let tau = 2.0 * PI / (k / m).sqrt() / 2000.0;
    let mut settings = settings(0.5, tau, n_steps);
    settings.output_every = output_every;
    settings.snapshot_steps = (first_snapshot..=n_steps).collect();
    // From rest at x = 0: the departure from the sliding equilibrium x_e = μN/k is −x_e.
    let x_e = mu * normal_force / k;
    let run = integrate(
        &structure,
        &contact_state,
        &settings,
        vec![0.0, -x_e, 0.0],
        vec![0.0; 3],
        &NoCheckpoints,
        |_| {},
    )
    .unwrap();
    (run, x_e)
}

#[test]
fn theta_at_least_one_half_is_stable_for_every_step_from_a_nanosecond_to_twenty_stiff_periods() {
    let case: Stress = reference::load("theta_method_stress");
    let (M, K, C) = chain_of(case.springs);
    let structure = Structure {
        M: &M,
        C: &C,
        K: &K,
        dof_of_node: &[],
        H_rows: Vec::new(),
        load: Load::default(),
    };
    for &tau in &case.taus {
        for &theta in &case.thetas {
            let run = integrate(
                &structure,
                &no_contact(),
                &settings(theta, tau, case.n_steps),
                vec![1.0, 0.0, -0.5],
                vec![0.0, 0.3, 0.0],
                &NoCheckpoints,
                |_| {},
            )
            .unwrap();
            let what = format!("θ = {theta}, τ = {tau:e} s");
            let energy = |row: &scheme::HistoryRow| row.energy.kinetic + row.energy.strain;
            let initial = energy(&run.history[0]);
            let tolerance = case.energy_tolerance * initial;
            for pair in run.history.windows(2) {
                let (before, after) = (energy(&pair[0]), energy(&pair[1]));
                assert!(
                    after <= before + tolerance,
                    "{what}: grows at t = {}",
                    pair[1].t
                );
                assert!(
                    pair[1].energy.balance_error.abs() <= tolerance,
                    "{what}: balance {:e} at t = {}",
                    pair[1].energy.balance_error,
                    pair[1].t
                );
                if theta == 0.5 {
                    assert!(
                        (after - initial).abs() <= tolerance,
                        "{what}: {after} against {initial}"
                    );
                }
            }
        }
    }
}

#[test]
fn a_million_steps_of_stick_slip_keep_the_balance_and_the_cycle() {
    let cycle: StickSlip = reference::load("stick_slip_oscillator");
    let case: Stress = reference::load("theta_method_stress");
    let (k, belt) = (cycle.stiffness, cycle.belt_speed);
    let omega = (k / cycle.mass).sqrt();
    let tau = 2.0 * PI / omega / 2000.0;
    let n_steps = case.long_run_steps;
    let (run, x_e) = stick_slip(&cycle, n_steps, 1000, n_steps - 2000);
    assert_eq!(run.history.last().unwrap().t, n_steps as f64 * tau);
    let scale = 0.5 * k * x_e * x_e;
    let worst = run
        .history
        .iter()
        .map(|row| row.energy.balance_error.abs())
        .fold(0.0, f64::max);
    assert!(
        worst < case.long_run_balance_tolerance * scale,
        "balance error {worst:e} J against {scale:e} J"
    );
    let x: Vec<f64> = run.snapshots.iter().map(|s| s.u[1]).collect();
    let amplitude = (x.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - x.iter().copied().fold(f64::INFINITY, f64::min))
        / 2.0;
    let expected = belt / omega;
    assert!(
        (amplitude - expected).abs() < case.long_run_amplitude_tolerance * expected,
        "amplitude {amplitude} against {expected} after {n_steps} steps"
    );
}

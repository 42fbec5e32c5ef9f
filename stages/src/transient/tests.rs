//! Verification of the transient: the θ-method against exact solutions (energy, modal
//! response, order), a mass dropped on a plane, the stick–slip oscillator, and the brake's
//! growth rate against the stability stage.

use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::sync::Arc;

use faer::{Mat, Side};

use super::contact::Solver;
use super::scheme::{ContactState, Settings, Structure, integrate};
use super::*;
use crate::artifact::CscMatrix;
use crate::assemble::test_model;
use crate::contact::lcp::LcpSettings;
use crate::equilibrium::{self, Load};
use crate::mesh::brake::{BrakeGeometry, brake};
use crate::stability::Stability;
use crate::stage::{Input, NoCheckpoints, Value};

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
        snapshot_steps: Vec::new(),
        sample_steps: Vec::new(),
    }
}

fn no_contact() -> ContactState {
    ContactState {
        gap: Vec::new(),
        sliding_speed: Vec::new(),
        r_e: Vec::new(),
        mu: 0.0,
    }
}

/// A chain of three unit masses between two walls, springs 1, 2, 3, 4 (ω from 1 to 2.6 rad/s).
fn chain() -> (CscMatrix, CscMatrix, CscMatrix) {
    let springs = [1.0, 2.0, 3.0, 4.0];
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
    let (_, run) = run_chain(0.5, 0.05, 500.0);
    assert_eq!(run.history.len(), 10_001);
    let initial = run.history[0].energy.kinetic + run.history[0].energy.strain;
    for row in &run.history {
        let total = row.energy.kinetic + row.energy.strain;
        assert!(
            (total - initial).abs() < 1e-11 * initial,
            "t = {}: {total} vs {initial}",
            row.t
        );
        assert!(row.energy.balance_error.abs() < 1e-11 * initial);
        assert_eq!(row.energy.scheme, 0.0);
    }
}

#[test]
fn the_response_converges_to_the_exact_modal_solution_at_the_scheme_order() {
    let (M, K, _) = chain();
    let _ = M;
    let duration = 10.0;
    let exact = exact_chain(&K, &[1.0, 0.0, -0.5], &[0.0, 0.3, 0.0], duration);
    for (theta, expected_order) in [(0.5, 2.0), (0.75, 1.0)] {
        let errors: Vec<(f64, f64)> = [0.02, 0.01, 0.005, 0.0025]
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
        // Least-squares slope of log(error) against log(tau).
        let points: Vec<(f64, f64)> = errors.iter().map(|(t, e)| (t.ln(), e.ln())).collect();
        let mean_x = points.iter().map(|p| p.0).sum::<f64>() / points.len() as f64;
        let mean_y = points.iter().map(|p| p.1).sum::<f64>() / points.len() as f64;
        let slope = points
            .iter()
            .map(|(x, y)| (x - mean_x) * (y - mean_y))
            .sum::<f64>()
            / points
                .iter()
                .map(|(x, _)| (x - mean_x).powi(2))
                .sum::<f64>();
        assert!(
            (slope - expected_order).abs() < 0.1,
            "theta = {theta}: order {slope}, errors {errors:?}"
        );
        if theta == 0.5 {
            assert!(errors[3].1 < 1e-4, "{errors:?}");
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
    let (M, K, C, H_rows) = point_on_plane(2.0, [0.0; 3]);
    let structure = Structure {
        M: &M,
        C: &C,
        K: &K,
        dof_of_node: &[],
        H_rows,
    };
    let gap = 0.01;
    let contact_state = ContactState {
        gap: vec![gap],
        sliding_speed: vec![0.5],
        r_e: vec![0.0; 3],
        mu: 0.3,
    };
    for theta in [0.5, 0.7, 1.0] {
        let tau = 1.3e-3;
        let mut settings = settings(theta, tau, 400);
        settings.record_pairs = vec![0];
        // Falling at 1 m/s: reaches the plane after about 7.7 steps.
        let run = integrate(
            &structure,
            &contact_state,
            &settings,
            vec![0.0; 3],
            vec![0.0, 0.0, -1.0],
            &NoCheckpoints,
            |_| {},
        )
        .unwrap();
        let impact = run
            .history
            .iter()
            .position(|row| gap + row.points[0].0 <= 1e-12)
            .expect("the mass reaches the plane");
        for row in &run.history {
            let (displacement, velocity) = row.points[0];
            assert!(
                gap + displacement >= -1e-12,
                "theta = {theta}: penetration {}",
                -(gap + displacement)
            );
            if row.t > run.history[impact].t + 1.5 * tau {
                // Inelastic: at rest on the plane from the step after contact on.
                assert!(
                    velocity.abs() < 1e-12,
                    "theta = {theta}, t = {}: v_n = {velocity}",
                    row.t
                );
            }
        }
        assert!(run.peak_penetration <= 1e-12);
        // The normal kinetic energy (½ m v² = 1 J) is lost in the impact, and the friction
        // impulse, μ times the normal one, drags the mass to μ × 1 m/s along the sliding disc
        // (0.3 < 0.5 m/s: it slides throughout).
        let last = run.history.last().unwrap();
        assert!((last.v_t - 0.3).abs() < 1e-12, "theta = {theta}: {last:?}");
        assert!((last.energy.kinetic - 0.09).abs() < 1e-12, "{last:?}");
        // θ = ½ books the whole loss to the impact; θ > ½ shares it with its own
        // dissipation (the balance holds either way).
        if theta == 0.5 {
            assert!((last.energy.normal + 1.0).abs() < 1e-12, "{last:?}");
            assert_eq!(last.energy.scheme, 0.0);
        } else {
            assert!(last.energy.scheme > 0.0, "{last:?}");
        }
        assert!(last.energy.balance_error.abs() < 1e-12, "{last:?}");
    }
}

#[test]
fn the_stick_slip_oscillator_settles_on_its_closed_form_cycle() {
    // m ẍ + k x = μ N while sliding on a belt at V: the limit cycle oscillates about μN/k with
    // amplitude V/ω, its velocity touching V once per period 2π/ω.
    let (m, k, normal_force, mu, belt) = (1.0, 400.0, 10.0, 0.4, 0.1);
    let (M, K, C, H_rows) = point_on_plane(m, [k, k, 1e4]);
    let structure = Structure {
        M: &M,
        C: &C,
        K: &K,
        dof_of_node: &[],
        H_rows,
    };
    let contact_state = ContactState {
        gap: vec![0.0],
        sliding_speed: vec![belt],
        r_e: vec![normal_force, mu * normal_force, 0.0],
        mu,
    };
    let omega = (k / m).sqrt();
    let period = 2.0 * PI / omega;
    let tau = period / 2000.0;
    let n_steps = 8 * 2000;
    let mut settings = settings(0.5, tau, n_steps);
    settings.snapshot_steps = (n_steps - 2 * 2000..=n_steps).collect();
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
    let last_period = &run.snapshots[run.snapshots.len() - 2001..];
    let x: Vec<f64> = last_period.iter().map(|s| x_e + s.u[1]).collect();
    let v: Vec<f64> = last_period.iter().map(|s| s.v[1]).collect();
    let (x_min, x_max) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        });
    let v_max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let amplitude = belt / omega;
    assert!(
        ((x_max + x_min) / 2.0 - x_e).abs() < 1e-3 * x_e,
        "centre {}",
        (x_max + x_min) / 2.0
    );
    assert!(
        ((x_max - x_min) / 2.0 - amplitude).abs() < 1e-3 * amplitude,
        "amplitude {}",
        (x_max - x_min) / 2.0
    );
    assert!((v_max - belt).abs() < 1e-3 * belt, "v_max {v_max}");
    // Period: upward zero crossings of the velocity over the last two periods, interpolated.
    let crossings: Vec<f64> = run.snapshots[run.snapshots.len() - 2 * 2000..]
        .windows(2)
        .filter(|pair| pair[0].v[1] < 0.0 && pair[1].v[1] >= 0.0)
        .map(|pair| {
            let (v0, v1) = (pair[0].v[1], pair[1].v[1]);
            pair[0].t + (pair[1].t - pair[0].t) * (-v0) / (v1 - v0)
        })
        .collect();
    assert!(crossings.len() >= 2, "{crossings:?}");
    let measured_period = crossings[crossings.len() - 1] - crossings[crossings.len() - 2];
    assert!(
        (measured_period - period).abs() < 1e-3 * period,
        "period {measured_period} against {period}"
    );
    // With one friction coefficient the cycle only touches the belt's speed: it sticks for
    // no longer than a few steps per period.
    let sticking = run.history[run.history.len() - 2000..]
        .iter()
        .filter(|row| row.stick > 0.0)
        .count();
    assert!(sticking <= 20, "{sticking} steps of the last period stick");
    assert!(run.history.last().unwrap().energy.balance_error.abs() < 1e-9 * 0.5 * k * x_e * x_e);
}

pub(crate) fn stage_params(overrides: &[(&str, Value)]) -> Params {
    crate::assemble::tests::params_of(&Transient, overrides)
}

/// A coarse brake through equilibrium and stability, as the transient's inputs.
pub(crate) fn brake_inputs() -> Inputs {
    let mesh = brake(&BrakeGeometry {
        n_radial: 3,
        n_theta: 24,
        n_thick: 1,
        pucks_radial: 1,
        pucks_angular: 1,
        puck_cells: 2,
        puck_layers: 1,
        ..BrakeGeometry::coarse()
    })
    .unwrap();
    let (model, _) = test_model(&mesh, "hub, pad_backs", &[]);
    let equilibrium = equilibrium::solve(
        &model,
        0.6,
        4.0,
        Load::Interference(5e-5),
        equilibrium::Solver::SemismoothNewton,
        &LcpSettings::default(),
    )
    .unwrap()
    .0;
    let model = Arc::new(Artifact::Model(Box::new(model)));
    let equilibrium = Arc::new(Artifact::Equilibrium(Box::new(equilibrium)));
    let mut inputs = Inputs(BTreeMap::from([
        ("model".to_string(), Input::One(model)),
        ("equilibrium".to_string(), Input::One(equilibrium)),
    ]));
    let stability_params = Params(
        Stability
            .params()
            .into_iter()
            .map(|spec| {
                let value = match spec.name {
                    "f_max_hz" => Value::Float(8000.0),
                    _ => spec.default.unwrap(),
                };
                (spec.name.to_string(), value)
            })
            .collect(),
    );
    let outputs = Stability.run(&stability_params, &inputs).unwrap();
    for port in ["eigenvalues", "shapes"] {
        inputs.0.insert(
            port.to_string(),
            Input::One(Arc::new(outputs[port].clone())),
        );
    }
    inputs
}

pub(crate) fn f64_column<'a>(table: &'a Table, name: &str) -> &'a [f64] {
    match table.column(name) {
        Some(ColumnData::F64(values)) => values,
        _ => panic!("no f64 column {name}"),
    }
}

/// The growth rate of the kinetic energy's envelope, `e^{2 σ t}`: σ fitted in log scale to
/// the per-period maxima, the first two periods left out.
pub(crate) fn growth_rate(history: &Table, period: f64, tau: f64) -> f64 {
    let t = f64_column(history, "t");
    let kinetic = f64_column(history, "kinetic");
    let per_period = (period / tau).round() as usize;
    let peaks: Vec<(f64, f64)> = kinetic
        .chunks(per_period)
        .zip(t.chunks(per_period))
        .skip(2)
        .filter(|(chunk, _)| chunk.len() == per_period)
        .map(|(chunk, times)| {
            let (idx, value) = chunk
                .iter()
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(b.1))
                .unwrap();
            (times[idx], value.ln())
        })
        .collect();
    let n = peaks.len() as f64;
    let mean_t = peaks.iter().map(|p| p.0).sum::<f64>() / n;
    let mean_y = peaks.iter().map(|p| p.1).sum::<f64>() / n;
    let slope = peaks
        .iter()
        .map(|(x, y)| (x - mean_t) * (y - mean_y))
        .sum::<f64>()
        / peaks.iter().map(|(x, _)| (x - mean_t).powi(2)).sum::<f64>();
    slope / 2.0
}

#[test]
fn the_brake_grows_at_the_rate_of_its_most_unstable_mode() {
    let inputs = brake_inputs();
    let eigenvalues = inputs.table("eigenvalues").unwrap();
    let re = f64_column(eigenvalues, "re");
    let im = f64_column(eigenvalues, "im");
    let most = (0..re.len())
        .max_by(|&a, &b| re[a].total_cmp(&re[b]))
        .unwrap();
    assert!(re[most] > 0.0, "the fixture has an unstable mode");
    let expected = re[most];
    let period = 2.0 * PI / im[most];
    let tau = period / 60.0;
    // Long enough for the growth to show over a few e-foldings, in the linear regime.
    let duration = (3.0 / expected).min(4000.0 * tau);
    let outputs = Transient
        .run(
            &stage_params(&[
                ("tau", Value::Float(tau)),
                ("duration", Value::Float(duration)),
                ("amplitude", Value::Float(1e-9)),
            ]),
            &inputs,
        )
        .unwrap();
    let history = outputs["history"].as_table().unwrap();
    let measured = growth_rate(history, period, tau);
    assert!(
        (measured - expected).abs() < 0.05 * expected,
        "growth rate {measured} /s against Re lambda = {expected} /s"
    );
    let energy = outputs["energy"].as_table().unwrap();
    let balance = f64_column(energy, "balance_error");
    let total: Vec<f64> = f64_column(energy, "kinetic")
        .iter()
        .zip(f64_column(energy, "strain"))
        .map(|(a, b)| a + b)
        .collect();
    let peak = total.iter().copied().fold(0.0, f64::max);
    let worst = balance.iter().map(|b| b.abs()).fold(0.0, f64::max);
    assert!(
        worst < 1e-8 * peak,
        "balance error {worst:e} J against peak energy {peak:e} J"
    );
}

#[test]
fn bad_parameters_are_refused_with_the_figure_that_matters() {
    let inputs = brake_inputs();
    for (overrides, expected) in [
        (
            vec![("tau", Value::Float(0.0))],
            "time step must be positive",
        ),
        (vec![("theta", Value::Float(0.4))], "theta = 0.4"),
        (
            vec![
                ("duration", Value::Float(1e-7)),
                ("tau", Value::Float(1e-6)),
            ],
            "shorter than one step",
        ),
        (
            vec![("mode", Value::Int(100_000))],
            "mode 100000 is not in the stability tables",
        ),
        (
            vec![("record_pairs", Value::Str("0, 9999".into()))],
            "record_pairs: `9999`",
        ),
        (
            vec![
                ("solver", Value::Str("fixed_point".into())),
                ("max_iterations", Value::Int(1)),
                ("tolerance", Value::Float(1e-300)),
                ("initial", Value::Str("kick".into())),
                ("kick_velocity", Value::Float(-1e-2)),
                ("duration", Value::Float(1e-4)),
            ],
            "did not converge at step",
        ),
    ] {
        let error = Transient
            .run(&stage_params(&overrides), &inputs)
            .unwrap_err();
        assert!(error.message.contains(expected), "{overrides:?}: {error}");
    }
}

/// Hoffmann's two-DOF model on a belt: a mass (x along the belt, y normal) held by springs k1,
/// k2 at 150° and 20°, pressed by a normal force N through a contact spring k3 onto a light
/// contact node (mass m_B, sharing x, its own normal DOF y_B) that slides on the belt at V.
/// DOFs: x, y_A, y_B. While the contact node slides, y_B = 0 and the linearised problem is
/// Hoffmann's: `diag(m + m_B, m) q̈ + [[k11, k12 + μ k3], [k12, k22 + k3]] q = 0`.
#[test]
fn hoffmanns_model_grows_at_its_linear_rate_then_saturates() {
    let (m, m_b, k3, mu, normal_force, belt) = (1.0, 1e-3, 1.0, 0.38, 1e-3, 0.01);
    let (a1, a2) = (150f64.to_radians(), 20f64.to_radians());
    let k11 = a1.cos().powi(2) + a2.cos().powi(2);
    let k12 = a1.cos() * a1.sin() + a2.cos() * a2.sin();
    let k22 = a1.sin().powi(2) + a2.sin().powi(2);
    let M = CscMatrix::from_triplets(3, 3, vec![(0, 0, m + m_b), (1, 1, m), (2, 2, m_b)]);
    let K = CscMatrix::from_triplets(
        3,
        3,
        vec![
            (0, 0, k11),
            (0, 1, k12),
            (1, 0, k12),
            (1, 1, k22 + k3),
            (1, 2, -k3),
            (2, 1, -k3),
            (2, 2, k3),
        ],
    );
    let C = CscMatrix::from_triplets(3, 3, Vec::new());
    // The linearised sliding problem and its most unstable eigenpair.
    let reduced_M = CscMatrix::from_triplets(2, 2, vec![(0, 0, m + m_b), (1, 1, m)]);
    let reduced_K = CscMatrix::from_triplets(
        2,
        2,
        vec![
            (0, 0, k11),
            (0, 1, k12 + mu * k3),
            (1, 0, k12),
            (1, 1, k22 + k3),
        ],
    );
    let no_damping = CscMatrix::from_triplets(2, 2, Vec::new());
    let pairs =
        crate::stability::lumped::solve_matrices(&reduced_M, &no_damping, &reduced_K, 0.0, 1e-12)
            .unwrap();
    let lambda = pairs
        .iter()
        .map(|pair| pair.lambda)
        .max_by(|a, b| a.re.total_cmp(&b.re))
        .unwrap();
    assert!(lambda.re > 0.0);
    // Its shape: the null vector of λ² M + K, scaled to 1e-5.
    let a11 = lambda * lambda * (m + m_b) + k11;
    let a12 = faer::c64::new(k12 + mu * k3, 0.0);
    let shape = [-a12, a11, faer::c64::new(0.0, 0.0)];
    let (u0, v0) = mode_start(lambda, &shape, 1e-8);
    let structure = Structure {
        M: &M,
        C: &C,
        K: &K,
        dof_of_node: &[],
        H_rows: vec![vec![(2, 1.0)], vec![(0, 1.0)], Vec::new()],
    };
    let contact_state = ContactState {
        gap: vec![0.0],
        sliding_speed: vec![belt],
        r_e: vec![normal_force, mu * normal_force, 0.0],
        mu,
    };
    let period = 2.0 * PI / lambda.im;
    let steps_per_period = 400;
    let tau = period / steps_per_period as f64;
    let n_periods = 90;
    let settings = settings(0.5, tau, n_periods * steps_per_period);
    let run = integrate(
        &structure,
        &contact_state,
        &settings,
        u0,
        v0,
        &NoCheckpoints,
        |_| {},
    )
    .unwrap();
    let peaks: Vec<(f64, f64)> = run
        .history
        .chunks(steps_per_period)
        .filter(|chunk| chunk.len() == steps_per_period)
        .map(|chunk| {
            let row = chunk
                .iter()
                .max_by(|a, b| a.kinetic.total_cmp(&b.kinetic))
                .unwrap();
            (row.t, row.kinetic)
        })
        .collect();
    // Linear growth while the contact slides throughout: the per-period peaks of the kinetic
    // energy grow as e^{2 Re λ t}, fitted over the first 15 periods.
    let early = &peaks[1..16];
    assert!(
        run.history[..16 * steps_per_period]
            .iter()
            .all(|row| row.slide == 1.0)
    );
    let n = early.len() as f64;
    let mean_t = early.iter().map(|p| p.0).sum::<f64>() / n;
    let mean_y = early.iter().map(|p| p.1.ln()).sum::<f64>() / n;
    let slope = early
        .iter()
        .map(|(t, e)| (t - mean_t) * (e.ln() - mean_y))
        .sum::<f64>()
        / early.iter().map(|(t, _)| (t - mean_t).powi(2)).sum::<f64>();
    let growth = slope / 2.0;
    assert!(
        (growth - lambda.re).abs() < 0.02 * lambda.re,
        "growth rate {growth} against Re lambda {}",
        lambda.re
    );
    // Saturation: the contact node lifts off the belt once the normal vibration outgrows the
    // preload, and the energy stays bounded (the peaks of the last 30 periods below 1.05 times
    // the first maximum, where the linear growth would have gone on by more than six decades).
    assert!(
        run.history.iter().any(|row| row.open > 0.0),
        "the contact never opens"
    );
    let first_maximum = peaks[40..60].iter().map(|p| p.1).fold(0.0, f64::max);
    let later_maximum = peaks[60..].iter().map(|p| p.1).fold(0.0, f64::max);
    assert!(
        later_maximum <= 1.05 * first_maximum,
        "{later_maximum} after {first_maximum}"
    );
    let linear = peaks[0].1 * (2.0 * lambda.re * (peaks.last().unwrap().0 - peaks[0].0)).exp();
    assert!(
        first_maximum < 1e-6 * linear,
        "{first_maximum} against {linear}"
    );
}

#[test]
fn stage_outputs_do_not_depend_on_the_thread_count() {
    let inputs = brake_inputs();
    let params = stage_params(&[
        ("tau", Value::Float(2e-6)),
        ("duration", Value::Float(4e-4)),
        ("amplitude", Value::Float(1e-6)),
    ]);
    crate::stage::assert_outputs_independent_of_threads(&Transient, &params, &inputs, "transient");
}

/// Checkpoints kept in memory, one due every `every` steps.
struct MemoryCheckpoints {
    saved: std::sync::Mutex<Option<Vec<u8>>>,
    calls: std::sync::atomic::AtomicUsize,
    every: usize,
}

impl crate::stage::Checkpoints for MemoryCheckpoints {
    fn load(&self) -> Option<Vec<u8>> {
        self.saved.lock().unwrap().clone()
    }
    fn due(&self) -> bool {
        let calls = self.calls.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1;
        calls.is_multiple_of(self.every)
    }
    fn save(&self, state: &[u8]) {
        *self.saved.lock().unwrap() = Some(state.to_vec());
    }
}

#[test]
fn a_run_stopped_part_way_resumes_from_its_checkpoint_to_the_same_bytes() {
    let inputs = brake_inputs();
    let params = stage_params(&[
        ("tau", Value::Float(2e-6)),
        ("duration", Value::Float(6e-4)),
        ("amplitude", Value::Float(1e-6)),
        ("output_every", Value::Int(3)),
        ("n_snapshots", Value::Int(40)),
    ]);
    let encode = |outputs: Outputs| -> Vec<(String, Vec<u8>)> {
        outputs
            .iter()
            .map(|(name, artifact)| (name.clone(), artifact.encode()))
            .collect()
    };
    let uninterrupted = encode(Transient.run(&params, &inputs).unwrap());
    let checkpoints = MemoryCheckpoints {
        saved: std::sync::Mutex::new(None),
        calls: std::sync::atomic::AtomicUsize::new(0),
        every: 37,
    };
    // Stopped at 70 % (a panic out of the progress report, as a kill would stop it).
    let stopping = crate::stage::Progress::new(|fraction, _| {
        if fraction >= 0.7 {
            panic!("stopped");
        }
    });
    let stopped = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        Transient.run_with(
            &params,
            &inputs,
            &RunContext {
                progress: &stopping,
                checkpoints: &checkpoints,
            },
        )
    }));
    assert!(stopped.is_err(), "the first run was stopped");
    assert!(
        checkpoints.saved.lock().unwrap().is_some(),
        "a checkpoint was kept"
    );
    // The resumed run starts where the checkpoint was taken: its first report is past half-way.
    let first_report = std::sync::Arc::new(std::sync::Mutex::new(None));
    let recording = {
        let first_report = first_report.clone();
        crate::stage::Progress::new(move |fraction, _| {
            first_report.lock().unwrap().get_or_insert(fraction);
        })
    };
    let resumed = Transient
        .run_with(
            &params,
            &inputs,
            &RunContext {
                progress: &recording,
                checkpoints: &checkpoints,
            },
        )
        .unwrap();
    let first = first_report.lock().unwrap().expect("progress was reported");
    assert!(first > 0.5, "the resumed run started at {first}");
    assert!(encode(resumed) == uninterrupted, "the resumed run differs");
}

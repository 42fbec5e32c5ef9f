//! `transient.matrices` on the lumped studies as shipped (`pipelines/stick_slip`,
//! `pipelines/hoffmann/transient.yaml`, their parameters read from the study files): the
//! stick–slip oscillator against its closed form as τ falls, and Hoffmann's model on a belt
//! growing at its linearised rate and settling on a limit cycle that converges as τ falls.

use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use squeal_stages::params::Params;
use squeal_stages::stability::matrices::solve_matrices;
use squeal_stages::stage::{Inputs, Outputs, Stage, Value};
use squeal_stages::table::{ColumnData, Table};
use squeal_stages::transient::lumped::TransientMatrices;
use squeal_stages::transient::lumped::model::read_matrix;

use crate::reference;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Cases {
    stick_slip: StickSlip,
    hoffmann: Hoffmann,
    /// Every run's worst balance error over its peak energy.
    balance_tolerance: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct StickSlip {
    mass: f64,
    stiffness: f64,
    normal_force: f64,
    mu: f64,
    mu_static: f64,
    belt_speed: f64,
    periods: usize,
    steps_per_period: Vec<usize>,
    /// The smooth cycle's period error falls at least this much per halving of τ.
    smooth_order_ratio: f64,
    smooth_amplitude_tolerance: f64,
    /// Steps of a period that may stick on the smooth cycle (it touches the belt's speed).
    most_touching_steps: usize,
    /// The cycle with sticks: period, stick time and amplitude errors within these many steps
    /// (the amplitude's in `V τ`).
    period_steps: f64,
    stick_steps: f64,
    amplitude_steps: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Hoffmann {
    growth_tolerance: f64,
    start_tolerance: f64,
    steps_per_period: Vec<usize>,
    /// The limit cycle is measured over the run's last `window` seconds.
    window: f64,
    period_tolerance: f64,
    x_tolerance: f64,
    y_tolerance: f64,
    /// Least share of the limit cycle's steps in each contact state.
    least_share: f64,
}

/// A parameter as a study writes it.
#[derive(Deserialize)]
#[serde(untagged)]
enum Written {
    Int(i64),
    Float(f64),
    Text(String),
    List(Vec<f64>),
}

#[derive(Deserialize)]
struct Study {
    stages: BTreeMap<String, StudyStage>,
}

#[derive(Deserialize)]
struct StudyStage {
    #[serde(default)]
    params: BTreeMap<String, Written>,
}

fn pipelines() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../pipelines")
}

/// Stage `stage` of the study `study` (under `pipelines/`) as written, with `overrides`; its
/// paths are relative to the study's folder.
fn study_params(study: &str, stage: &str, overrides: &[(&str, Value)]) -> Params {
    let path = pipelines().join(study);
    let text = std::fs::read_to_string(&path).unwrap();
    let study: Study = serde_saphyr::from_str(&text).unwrap();
    let folder = path.parent().unwrap();
    let mut values: Vec<(String, Value)> = study.stages[stage]
        .params
        .iter()
        .map(|(name, written)| {
            let value = match written {
                Written::Int(value) => Value::Int(*value),
                Written::Float(value) => Value::Float(*value),
                Written::Text(text) if name.ends_with("_path") => {
                    Value::Str(folder.join(text).display().to_string())
                }
                Written::Text(text) => Value::Str(text.clone()),
                Written::List(items) => Value::Str(
                    items
                        .iter()
                        .map(|item| item.to_string())
                        .collect::<Vec<_>>()
                        .join(", "),
                ),
            };
            (name.clone(), value)
        })
        .collect();
    for (name, value) in overrides {
        values.retain(|(other, _)| other != name);
        values.push((name.to_string(), value.clone()));
    }
    let borrowed: Vec<(&str, Value)> = values
        .iter()
        .map(|(name, value)| (name.as_str(), value.clone()))
        .collect();
    Params::defaults(&TransientMatrices, &borrowed)
}

fn run(params: &Params) -> Outputs {
    TransientMatrices
        .run(params, &Inputs::default())
        .unwrap_or_else(|err| panic!("{}", err.message))
}

fn table<'a>(outputs: &'a Outputs, name: &str) -> &'a Table {
    outputs[name].as_table().unwrap()
}

fn states(contacts: &Table) -> Vec<String> {
    match contacts.column("state") {
        Some(ColumnData::Str(states)) => states.clone(),
        _ => panic!("no state column"),
    }
}

fn check_balance(outputs: &Outputs, tolerance: f64, what: &str) {
    let balance = table(outputs, "summary")
        .quantity("relative_balance_error")
        .unwrap();
    assert!(balance <= tolerance, "{what}: balance error {balance:e}");
}

/// The times `x` crosses `level` upwards, interpolated.
fn upward_crossings(t: &[f64], x: &[f64], level: f64) -> Vec<f64> {
    (1..t.len())
        .filter(|&k| x[k - 1] < level && x[k] >= level)
        .map(|k| t[k - 1] + (t[k] - t[k - 1]) * (level - x[k - 1]) / (x[k] - x[k - 1]))
        .collect()
}

/// A cycle measured over its last `count` periods (between upward crossings of its mid-level,
/// found over the last `span` seconds): period, amplitude, and the time per period spent in
/// contact state `state` (from one contact's rows, one per history row).
fn cycle(t: &[f64], x: &[f64], states: &[String], span: f64, count: usize) -> [f64; 3] {
    let end = *t.last().unwrap();
    let recent: Vec<usize> = (0..t.len()).filter(|&k| t[k] > end - span).collect();
    let (low, high) = recent
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(low, high), &k| {
            (low.min(x[k]), high.max(x[k]))
        });
    let crossings = upward_crossings(t, x, 0.5 * (low + high));
    assert!(crossings.len() > count, "{} crossings", crossings.len());
    let (first, last) = (
        crossings[crossings.len() - 1 - count],
        crossings[crossings.len() - 1],
    );
    let window: Vec<usize> = (0..t.len())
        .filter(|&k| t[k] >= first && t[k] < last)
        .collect();
    let (low, high) = window
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(low, high), &k| {
            (low.min(x[k]), high.max(x[k]))
        });
    let tau = t[1] - t[0];
    let sticking = window.iter().filter(|&&k| states[k] == "stick").count();
    [
        (last - first) / count as f64,
        0.5 * (high - low),
        sticking as f64 * tau / count as f64,
    ]
}

#[test]
fn the_stick_slip_oscillator_converges_on_its_closed_form_cycle_as_tau_falls() {
    let cases: Cases = reference::load("lumped_transient");
    let case = &cases.stick_slip;
    let (k, m, normal, belt) = (
        case.stiffness,
        case.mass,
        case.normal_force,
        case.belt_speed,
    );
    let omega = (k / m).sqrt();
    let linear_period = 2.0 * PI / omega;
    for mu_static in [case.mu, case.mu_static] {
        // The closed form (the module doc of the reference values).
        let d = (mu_static - case.mu) * normal / k;
        let (period, amplitude, stick) = if d > 0.0 {
            let alpha = (belt / (omega * d)).atan();
            (
                2.0 * d / belt + (PI + 2.0 * alpha) / omega,
                d.hypot(belt / omega),
                2.0 * d / belt,
            )
        } else {
            (linear_period, belt / omega, 0.0)
        };
        for pulled in [false, true] {
            let mut period_errors = Vec::new();
            for &steps in &case.steps_per_period {
                let tau = linear_period / steps as f64;
                let duration = case.periods as f64 * linear_period;
                let stage = if pulled { "pulled" } else { "belt" };
                let outputs = run(&study_params(
                    "stick_slip/stick_slip.yaml",
                    stage,
                    &[
                        ("tau", Value::Float(tau)),
                        ("duration", Value::Float(duration)),
                        ("mu_static", Value::Float(mu_static)),
                    ],
                ));
                let what = format!("mu_s = {mu_static}, {stage}, {steps} steps a period");
                check_balance(&outputs, cases.balance_tolerance, &what);
                let history = table(&outputs, "history");
                let t = history.f64("t").unwrap();
                let q = history.f64("q_0").unwrap();
                // Pulled, the spring's extension V t − x mirrors the belt's x.
                let x: Vec<f64> = if pulled {
                    t.iter().zip(q).map(|(t, q)| belt * t - q).collect()
                } else {
                    q.to_vec()
                };
                let contact_states = states(table(&outputs, "contacts"));
                let [measured_period, measured_amplitude, measured_stick] =
                    cycle(t, &x, &contact_states, 3.0 * period, 3);
                if d > 0.0 {
                    assert!(
                        (measured_period - period).abs() <= case.period_steps * tau,
                        "{what}: period {measured_period} against {period}"
                    );
                    assert!(
                        (measured_stick - stick).abs() <= case.stick_steps * tau,
                        "{what}: stick time {measured_stick} against {stick}"
                    );
                    assert!(
                        (measured_amplitude - amplitude).abs() <= case.amplitude_steps * belt * tau,
                        "{what}: amplitude {measured_amplitude} against {amplitude}"
                    );
                } else {
                    period_errors.push((measured_period - period).abs());
                    assert!(
                        (measured_amplitude - amplitude).abs()
                            <= case.smooth_amplitude_tolerance * amplitude,
                        "{what}: amplitude {measured_amplitude} against {amplitude}"
                    );
                    assert!(
                        measured_stick <= case.most_touching_steps as f64 * tau,
                        "{what}: sticks {measured_stick} s a period"
                    );
                }
            }
            for pair in period_errors.windows(2) {
                assert!(
                    pair[0] >= case.smooth_order_ratio * pair[1],
                    "mu_s = mu, pulled = {pulled}: period errors {period_errors:?}"
                );
            }
        }
    }
}

/// The limit cycle of Hoffmann's model on a belt over the run's last `window` seconds: period,
/// amplitudes of x and y_A, and the shares of its steps open, sticking and slipping.
fn hoffmann_cycle(outputs: &Outputs, window: f64) -> ([f64; 3], [f64; 3]) {
    let history = table(outputs, "history");
    let t = history.f64("t").unwrap();
    let (x, y) = (history.f64("q_0").unwrap(), history.f64("q_1").unwrap());
    let contact_states = states(table(outputs, "contacts"));
    let end = *t.last().unwrap();
    let last: Vec<usize> = (0..t.len()).filter(|&k| t[k] > end - window).collect();
    let share = |state: &str| {
        last.iter().filter(|&&k| contact_states[k] == state).count() as f64 / last.len() as f64
    };
    let span = |values: &[f64]| {
        let (low, high) = last
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(low, high), &k| {
                (low.min(values[k]), high.max(values[k]))
            });
        0.5 * (high - low)
    };
    let [period, _, _] = cycle(t, x, &contact_states, window, 5);
    (
        [period, span(x), span(y)],
        [share("open"), share("stick"), share("slip")],
    )
}

#[test]
fn hoffmanns_model_on_a_belt_grows_at_its_sliding_rate_and_settles_on_a_converged_limit_cycle() {
    let cases: Cases = reference::load("lumped_transient");
    let case = &cases.hoffmann;
    let folder = pipelines().join("hoffmann");
    let sliding = solve_matrices(
        &read_matrix(&folder.join("M_sliding.mtx")).unwrap(),
        &read_matrix(&folder.join("C.mtx")).unwrap(),
        &read_matrix(&folder.join("K.mtx")).unwrap(),
        0.0,
        1e-12,
    )
    .unwrap();
    let lambda = sliding
        .iter()
        .map(|pair| pair.lambda)
        .max_by(|a, b| a.re.total_cmp(&b.re))
        .unwrap();
    let linear_period = 2.0 * PI / lambda.im;
    let mut cycles = Vec::new();
    for &steps in &case.steps_per_period {
        let tau = linear_period / steps as f64;
        let outputs = run(&study_params(
            "hoffmann/transient.yaml",
            "transient",
            &[("tau", Value::Float(tau))],
        ));
        let what = format!("{steps} steps a period");
        check_balance(&outputs, cases.balance_tolerance, &what);
        let start = table(&outputs, "summary")
            .quantity("start_growth_rate")
            .unwrap();
        assert!(
            (start - lambda.re).abs() <= case.start_tolerance * lambda.re,
            "{what}: the sliding state's Re lambda {start} against {}",
            lambda.re
        );
        // Linear growth while the contact slides: the per-period peaks of the kinetic energy
        // grow as e^{2 Re λ t}, fitted over the first 15 periods.
        let energy = table(&outputs, "energy");
        let (t, kinetic) = (energy.f64("t").unwrap(), energy.f64("kinetic").unwrap());
        let peaks: Vec<(f64, f64)> = (1..16)
            .map(|period| {
                (0..t.len())
                    .filter(|&k| {
                        let phase = t[k] / linear_period;
                        phase >= period as f64 && phase < (period + 1) as f64
                    })
                    .map(|k| (t[k], kinetic[k].ln()))
                    .max_by(|a, b| a.1.total_cmp(&b.1))
                    .unwrap()
            })
            .collect();
        let slip_until = 16.0 * linear_period;
        let contacts = table(&outputs, "contacts");
        let contact_states = states(contacts);
        let contact_t = contacts.f64("t").unwrap();
        assert!(
            (0..contact_t.len())
                .filter(|&k| contact_t[k] <= slip_until)
                .all(|k| contact_states[k] == "slip"),
            "{what}: the contact leaves sliding in the first 16 periods"
        );
        let growth = crate::fit::slope(&peaks) / 2.0;
        assert!(
            (growth - lambda.re).abs() <= case.growth_tolerance * lambda.re,
            "{what}: growth rate {growth} against Re lambda {}",
            lambda.re
        );
        let (cycle, shares) = hoffmann_cycle(&outputs, case.window);
        assert!(
            shares.iter().all(|&share| share >= case.least_share),
            "{what}: open, stick, slip shares {shares:?}"
        );
        cycles.push(cycle);
    }
    // The changes shrink as τ halves, and the finest two agree.
    let tolerances = [case.period_tolerance, case.x_tolerance, case.y_tolerance];
    for quantity in 0..3 {
        let values: Vec<f64> = cycles.iter().map(|cycle| cycle[quantity]).collect();
        let changes: Vec<f64> = values
            .windows(2)
            .map(|pair| (pair[1] - pair[0]).abs())
            .collect();
        assert!(
            changes.windows(2).all(|pair| pair[1] < pair[0]),
            "quantity {quantity}: {values:?}"
        );
        let finest = values[values.len() - 1];
        assert!(
            changes[changes.len() - 1] <= tolerances[quantity] * finest.abs(),
            "quantity {quantity}: {values:?}"
        );
    }
}

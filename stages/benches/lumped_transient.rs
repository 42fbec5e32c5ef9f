//! `transient.matrices` on the stick–slip oscillator of `pipelines/stick_slip/stick_slip.yaml`
//! (stage `belt`, static friction 0.5 over kinetic 0.4, 2,000 steps a period), back to back with
//! the same scheme as a Python loop with numpy (`lumped_transient_numpy.py`, which must end on
//! the same state): the time a step takes in the scheme, recording every step as the stage
//! does and recording none, the whole stage (its tables and figures too), and the Python
//! loop's. Each is the best of three runs.
//!
//! Run with `cargo bench -p squeal-stages --bench lumped_transient`; `SQUEAL_BENCH_STEPS`
//! (240,000) overrides the run's length.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use squeal_stages::stage::{Inputs, Params, Value};
use squeal_stages::transient::lumped::{LumpedRun, TransientMatrices, read_model};
use squeal_stages::transient::scheme::{Settings, integrate};
use squeal_stages::{NoCheckpoints, Stage};

fn best_of_three(mut run: impl FnMut() -> f64) -> f64 {
    (0..3).map(|_| run()).fold(f64::INFINITY, f64::min)
}

fn main() {
    let steps: usize = std::env::var("SQUEAL_BENCH_STEPS")
        .ok()
        .and_then(|value| value.parse().ok())
        .unwrap_or(240_000);
    let study = Path::new(env!("CARGO_MANIFEST_DIR")).join("../pipelines/stick_slip");
    let file = |name: &str| Value::Str(study.join(name).display().to_string());
    let tau = 2.0 * std::f64::consts::PI / 20.0 / 2000.0;
    let params = Params::defaults(
        &TransientMatrices,
        &[
            ("m_path", file("M.mtx")),
            ("k_path", file("K.mtx")),
            ("contacts_path", file("contacts.yaml")),
            ("load", Value::Str("0, -10".into())),
            ("mu", Value::Float(0.4)),
            ("mu_static", Value::Float(0.5)),
            ("surface_speed", Value::Float(0.1)),
            ("tau", Value::Float(tau)),
            ("duration", Value::Float(steps as f64 * tau)),
            ("tolerance", Value::Float(1e-12)),
        ],
    );
    let read = params.read::<TransientMatrices>().expect("parameters");
    let model = read_model(&read).expect("model");
    let lumped = LumpedRun::new(&model, &read).expect("lumped run");
    let structure = lumped.structure();
    let recording = Settings {
        record_dofs: lumped.free_records(),
        record_contacts: true,
        ..read.scheme.settings()
    };
    let silent = Settings {
        output_every: steps,
        ..read.scheme.settings()
    };
    // The best of three runs' seconds, and the last row's x and v.
    let time_steps = |settings: &Settings| {
        let mut last_state = (f64::NAN, f64::NAN);
        let seconds = best_of_three(|| {
            let clock = Instant::now();
            let run = integrate(
                &structure,
                &lumped.contact_state,
                settings,
                lumped.u0.clone(),
                lumped.v0.clone(),
                &NoCheckpoints,
                |_| {},
            )
            .expect("run");
            let seconds = clock.elapsed().as_secs_f64();
            let last = run.history.last().expect("a history row");
            last_state = last.dofs.first().copied().unwrap_or(last_state);
            seconds
        });
        (seconds, last_state)
    };
    let (recorded, (x, v)) = time_steps(&recording);
    let (unrecorded, _) = time_steps(&silent);
    let stage = best_of_three(|| {
        let clock = Instant::now();
        TransientMatrices
            .run(&params, &Inputs::default())
            .expect("stage");
        clock.elapsed().as_secs_f64()
    });
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/lumped_transient_numpy.py");
    let mut python_state = (f64::NAN, f64::NAN);
    let python = best_of_three(|| {
        let output = Command::new("python3")
            .arg(&script)
            .arg(steps.to_string())
            .output()
            .expect("python3 (with numpy and scipy)");
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        let text = String::from_utf8_lossy(&output.stdout);
        let fields: Vec<f64> = text
            .split_whitespace()
            .map(|field| field.parse().expect("a number"))
            .collect();
        python_state = (fields[1], fields[2]);
        fields[0]
    });
    let per_step = |seconds: f64| 1e6 * seconds / steps as f64;
    println!("stick-slip oscillator, {steps} steps (tau = {tau:.4e} s), best of three:");
    println!(
        "  scheme, recording every step  {:8.3} us a step",
        per_step(recorded)
    );
    println!(
        "  scheme, recording none        {:8.3} us a step",
        per_step(unrecorded)
    );
    println!(
        "  the whole stage (tables, figures) {:8.3} us a step",
        per_step(stage)
    );
    println!(
        "  Python loop with numpy        {:8.3} us a step",
        per_step(python)
    );
    println!(
        "  Python / scheme recording every step: {:.1}x; / the whole stage: {:.1}x",
        python / recorded,
        python / stage
    );
    let difference = (x - python_state.0).abs().max((v - python_state.1).abs());
    println!("  final x, v: {x:.12e} m, {v:.12e} m/s; Python's differ by {difference:.2e}");
    assert!(
        difference < 1e-9 * (x.abs() + v.abs()),
        "the Python loop does not integrate the same scheme"
    );
}

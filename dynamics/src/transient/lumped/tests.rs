//! `transient.matrices`: the sliding state of Hoffmann's model on a belt against Hoffmann's
//! matrices, a driven DOF against the same model on a belt, and every refusal. (The closed
//! forms of the stick–slip oscillator and Hoffmann's growth and limit cycle are in the
//! verification suite, `lumped_transient.rs`.)

use std::path::{Path, PathBuf};

use super::*;
use crate::stage::{Inputs, Value};
use crate::table::Table;

fn pipelines() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../pipelines")
}

fn file(relative: &str) -> Value {
    Value::Str(pipelines().join(relative).display().to_string())
}

/// The parameters `all`, with `overrides` in place of those of their names.
fn overridden<'a>(mut all: Vec<(&'a str, Value)>, overrides: &[(&'a str, Value)]) -> Params {
    for (name, value) in overrides {
        all.retain(|(other, _)| other != name);
        all.push((name, value.clone()));
    }
    Params::defaults(&TransientMatrices, &all)
}

/// The stick–slip oscillator on its belt (`pipelines/stick_slip`), static friction 0.5 over
/// kinetic 0.4, for `duration` s, with `overrides`.
fn stick_slip(duration: f64, overrides: &[(&str, Value)]) -> Params {
    let all = vec![
        ("m_path", file("stick_slip/M.mtx")),
        ("k_path", file("stick_slip/K.mtx")),
        ("contacts_path", file("stick_slip/contacts.yaml")),
        ("load", Value::Str("0, -10".into())),
        ("mu", Value::Float(0.4)),
        ("mu_static", Value::Float(0.5)),
        ("surface_speed", Value::Float(0.1)),
        ("tau", Value::Float(1.5707963267948966e-4)),
        ("duration", Value::Float(duration)),
        ("tolerance", Value::Float(1e-12)),
    ];
    overridden(all, overrides)
}

/// Hoffmann's model on a belt (`pipelines/hoffmann/transient.yaml`), with `overrides`.
fn hoffmann(overrides: &[(&str, Value)]) -> Params {
    let all = vec![
        ("m_path", file("hoffmann/M_belt.mtx")),
        ("k_path", file("hoffmann/K_belt.mtx")),
        ("contacts_path", file("hoffmann/contacts_belt.yaml")),
        ("load", Value::Str("0, -1e-3, 0".into())),
        ("mu", Value::Float(0.38)),
        ("surface_speed", Value::Float(1e-4)),
        ("initial", Value::Str("mode".into())),
        ("amplitude", Value::Float(1e-8)),
        ("tau", Value::Float(0.0128)),
        ("duration", Value::Float(20.0)),
        ("tolerance", Value::Float(1e-12)),
    ];
    overridden(all, overrides)
}

fn run(params: &Params) -> Result<Outputs, StageError> {
    TransientMatrices.run(params, &Inputs::default())
}

fn table<'a>(outputs: &'a Outputs, name: &str) -> &'a Table {
    outputs[name].as_table().unwrap()
}

fn error(params: &Params) -> String {
    match run(params) {
        Ok(_) => panic!("the run should have been refused"),
        Err(err) => err.message,
    }
}

/// A file in a fresh temporary folder.
fn written(name: &str, text: &str) -> (tempfile::TempDir, Value) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    let value = Value::Str(path.display().to_string());
    (dir, value)
}

#[test]
fn hoffmanns_model_on_a_belt_slides_on_hoffmanns_linearised_problem() {
    // With the contact node held on the belt and pushing along n + μ t, the linearised problem
    // over (x, y_A) is Hoffmann's: K = [[k11, k12 + μ k3], [k12, k22 + k3]], diag(m + m_B, m).
    let params = hoffmann(&[]);
    let model = read_model(&params.read::<TransientMatrices>().unwrap()).unwrap();
    let free = model.free_dofs();
    let speeds = [1e-4];
    let sliding = Sliding {
        model: &model,
        free: &free,
        speeds: &speeds,
        mu: &[0.38],
    };
    let load = [0.0, -1e-3, 0.0];
    // The springs carry part of the 1e-3 N load on y_A; the node stays on the belt.
    let equilibrium = sliding.equilibrium(&load).unwrap();
    assert!(
        equilibrium.closed[0] && equilibrium.r_n[0] > 0.0,
        "{equilibrium:?}"
    );
    assert!(equilibrium.residual < 1e-14, "{equilibrium:?}");
    assert_eq!(equilibrium.q[2], 0.0);
    let modes = sliding.modes(&equilibrium).unwrap();
    let K = read_matrix(&pipelines().join("hoffmann/K.mtx")).unwrap();
    let M = read_matrix(&pipelines().join("hoffmann/M_sliding.mtx")).unwrap();
    let C = CscMatrix::from_triplets(2, 2, Vec::new());
    let reference = crate::stability::matrices::solve_matrices(&M, &C, &K, 0.0, 1e-12).unwrap();
    let growing = reference
        .iter()
        .map(|pair| pair.lambda)
        .max_by(|a, b| a.re.total_cmp(&b.re))
        .unwrap();
    let (lambda, shape) = &modes[0];
    assert!(
        (lambda - growing).norm() < 1e-12 * growing.norm(),
        "{lambda} against {growing}"
    );
    // The mode keeps the node on the belt.
    let largest = shape.iter().map(|value| value.norm()).fold(0.0, f64::max);
    assert!(shape[2].norm() < 1e-12 * largest, "{shape:?}");
    // The stage starts from it, and says so.
    let outputs = run(&params).unwrap();
    let summary = table(&outputs, "summary");
    let rate = summary.quantity("start_growth_rate").unwrap();
    assert!((rate - growing.re).abs() < 1e-12, "{rate}");
}

#[test]
fn a_spring_driven_at_a_prescribed_velocity_acts_as_the_belt_seen_from_the_mass() {
    // The stick–slip oscillator both ways (`pipelines/stick_slip`): on a belt at V from rest,
    // and on still ground with its spring's far end driven at V, the mass starting at V too.
    // Mirror images: x_belt = V t − x_pulled.
    let belt = run(&stick_slip(0.7, &[])).unwrap();
    let pulled = run(&stick_slip(
        0.7,
        &[
            ("m_path", file("stick_slip/M_pulled.mtx")),
            ("k_path", file("stick_slip/K_pulled.mtx")),
            ("contacts_path", file("stick_slip/contacts_pulled.yaml")),
            ("load", Value::Str("0, -10, 0".into())),
            ("surface_speed", Value::Float(0.0)),
            ("prescribed_dofs", Value::Str("2".into())),
            ("prescribed_velocities", Value::Str("0.1".into())),
            ("initial", Value::Str("given".into())),
            ("v0", Value::Str("0.1, 0, 0.1".into())),
        ],
    ))
    .unwrap();
    let (belt, pulled) = (table(&belt, "history"), table(&pulled, "history"));
    let t = belt.f64("t").unwrap();
    let (x_belt, x_pulled) = (belt.f64("q_0").unwrap(), pulled.f64("q_0").unwrap());
    let end = pulled.f64("q_2").unwrap();
    let mut worst: f64 = 0.0;
    for k in 0..t.len() {
        assert!(
            (end[k] - 0.1 * t[k]).abs() < 1e-15,
            "the driven end at {}",
            t[k]
        );
        worst = worst.max((x_belt[k] - (end[k] - x_pulled[k])).abs());
    }
    // 4,500 steps through sticks and slips: the two agree to the contact solves' tolerance.
    assert!(worst < 1e-12, "{worst}");
}

#[test]
fn a_contact_given_its_own_surface_speed_and_friction_runs_as_with_the_studys() {
    // The stick–slip oscillator with μ, μ_s and V in the study, then in its contact.
    let in_the_study = run(&stick_slip(0.5, &[])).unwrap();
    let (_dir, contacts) = written(
        "contacts.yaml",
        "- normal: [0, 1]\n  tangent: [1, 0]\n  surface_speed: 0.1\n  mu: 0.4\n  mu_static: 0.5\n",
    );
    let in_the_contact = run(&stick_slip(
        0.5,
        &[
            ("contacts_path", contacts),
            ("mu", Value::Float(0.0)),
            ("mu_static", Value::Float(0.0)),
            ("surface_speed", Value::Float(0.0)),
        ],
    ))
    .unwrap();
    for name in ["history", "contacts", "energy"] {
        assert!(
            in_the_study[name].encode() == in_the_contact[name].encode(),
            "{name} differs"
        );
    }
    let stuck = table(&in_the_contact, "summary")
        .quantity("share_stick")
        .unwrap();
    assert!(stuck > 0.1, "{stuck}");
}

#[test]
fn a_lumped_run_stopped_part_way_resumes_from_its_checkpoint_to_the_same_bytes() {
    // The stick–slip oscillator with static friction: the checkpoint carries which contacts
    // stuck, as well as the state and the contact solver's memory.
    let params = stick_slip(1.0, &[]);
    super::super::tests::assert_resumes_to_the_same_bytes(
        &TransientMatrices,
        &params,
        &Inputs::default(),
        997,
    );
}

#[test]
fn a_lumped_model_refuses_what_it_cannot_integrate_and_says_why() {
    let cases: Vec<(Vec<(&str, Value)>, &str)> = vec![
        (
            vec![("m_path", file("hoffmann/M.mtx"))],
            "K is 3 x 3, M is 2 x 2: the matrices must be square and of one size",
        ),
        (
            vec![
                ("k_path", file("hoffmann/K.mtx")),
                ("m_path", file("hoffmann/M.mtx")),
            ],
            "K is not symmetric (largest |K - K^T| is 2.33e-1 of its largest entry): friction enters through the contacts, not through K",
        ),
        (
            vec![("load", Value::Str("0, -1e-3".into()))],
            "load has 2 entries, the model 3 DOFs",
        ),
        (
            vec![("mu_static", Value::Float(0.2))],
            "mu_static = 0.2 is below mu = 0.38",
        ),
        (
            vec![
                ("prescribed_dofs", Value::Str("2".into())),
                ("prescribed_velocities", Value::Str("0.1".into())),
            ],
            "contact 0: its normal row moves DOF 2, which is driven at a prescribed velocity",
        ),
        (
            vec![
                ("prescribed_dofs", Value::Str("0, 1".into())),
                ("prescribed_velocities", Value::Str("0.1".into())),
            ],
            "prescribed_dofs has 2 DOFs, prescribed_velocities 1 velocities",
        ),
        (
            vec![
                ("prescribed_dofs", Value::Str("7".into())),
                ("prescribed_velocities", Value::Str("0.1".into())),
            ],
            "prescribed_dofs: DOF 7 is not among the model's 3 DOFs (0 to 2)",
        ),
        (
            vec![("mu", Value::Float(0.1))],
            "the sliding state is stable (largest Re lambda = ",
        ),
        (
            vec![("surface_speed", Value::Float(0.0))],
            "contact 0 closes at rest on a surface that does not move",
        ),
        (
            vec![
                ("initial", Value::Str("given".into())),
                ("u0", Value::Str("1, 2".into())),
            ],
            "u0 has 2 entries, the model 3 DOFs",
        ),
        (
            vec![
                ("prescribed_dofs", Value::Str("0".into())),
                ("prescribed_velocities", Value::Str("0.1".into())),
                ("initial", Value::Str("given".into())),
                ("v0", Value::Str("0.2, 0, 0".into())),
            ],
            "v0 gives DOF 0 a velocity of 0.2 m/s, but it is driven at 0.1 m/s",
        ),
        (
            vec![("record_dofs", Value::Str("0, 3".into()))],
            "record_dofs: DOF 3 is not among the model's 3 DOFs (0 to 2)",
        ),
        (
            vec![("tau", Value::Float(0.0))],
            "tau = 0 s: the time step must be positive",
        ),
    ];
    for (overrides, expected) in cases {
        let message = error(&hoffmann(&overrides));
        assert!(message.contains(expected), "{overrides:?}: {message}");
    }
    // A contacts file with a row of the wrong length, an unknown key, or a zero row.
    for (text, expected) in [
        (
            "- normal: [0, 1]\n  tangent: [1, 0, 0]\n",
            "contact 0: its normal row has 2 entries, the model 3 DOFs",
        ),
        (
            "- normal: [0, 0, 1]\n  tangent: [1, 0, 0]\n  gapp: 0\n",
            "contacts.yaml:3:3: unknown field `gapp`",
        ),
        (
            "- normal: [0, 0, 1]\n  tangent: [0, 0, 0]\n",
            "contact 0: its tangent row is zero: it moves no DOF",
        ),
    ] {
        let (_dir, path) = written("contacts.yaml", text);
        let message = error(&hoffmann(&[("contacts_path", path)]));
        assert!(message.contains(expected), "{text}: {message}");
    }
    // A mass matrix that is not symmetric.
    let (_dir, path) = written(
        "M.mtx",
        "%%MatrixMarket matrix coordinate real general\n3 3 4\n1 1 1\n2 2 1\n3 3 1e-3\n1 2 0.5\n",
    );
    let message = error(&hoffmann(&[("m_path", path)]));
    assert!(message.starts_with("M is not symmetric"), "{message}");
}

//! The `modes` stage: its outputs, their reproducibility across thread counts, and its errors.
//! The eigensolver's accuracy (rigid-body modes, Euler–Bernoulli, Kirchhoff plate, dense
//! solves) is verified in `tests/verification`.

use std::collections::BTreeMap;
use std::sync::Arc;

use super::Modes;
use crate::artifact::Artifact;
use crate::artifact::Model;
use crate::fixtures::assemble;
use crate::mesh::structured;
use crate::stage::{Input, Inputs, Params, Stage, StageError, Value};
use crate::table::ColumnData;

/// A cantilever of length `length` and square section `side`, clamped at x = 0.
fn cantilever(length: f64, side: f64, n_length: usize, n_side: usize) -> Model {
    let mesh = structured::block([length, side, side], [n_length, n_side, n_side], "disc");
    assemble(&mesh, "x0").0
}

fn run_stage(
    model: &Model,
    overrides: &[(&str, Value)],
) -> Result<crate::stage::Outputs, StageError> {
    let params = Params::defaults(&Modes, overrides);
    let inputs = Inputs(BTreeMap::from([(
        "model".to_string(),
        Input::One(Arc::new(Artifact::Model(Box::new(model.clone())))),
    )]));
    Modes.run(&params, &inputs)
}

#[test]
fn stage_outputs_are_reproducible_and_shaped_as_documented() {
    let model = cantilever(0.3, 0.03, 30, 2);
    let first = run_stage(&model, &[("n_modes", Value::Int(8))]).unwrap();
    let second = run_stage(&model, &[("n_modes", Value::Int(8))]).unwrap();
    for name in ["modes", "frequencies", "shapes"] {
        assert_eq!(first[name].encode(), second[name].encode(), "output {name}");
    }
    let table = first["frequencies"].as_table().unwrap();
    assert_eq!(table.n_rows(), 8);
    for column in [
        "mode",
        "freq_hz",
        "omega",
        "residual",
        "effective_mass_z_kg",
    ] {
        assert!(table.column(column).is_some(), "column {column}");
    }
    let shapes = first["shapes"].as_table().unwrap();
    assert_eq!(shapes.n_rows(), 3 * model.mesh.n_nodes());
    assert_eq!(shapes.columns().len(), 3 + 8);
    assert!(matches!(
        shapes.column("mode_0008"),
        Some(ColumnData::F64(_))
    ));
    match &first["modes"] {
        Artifact::RealModes(modes) => {
            assert_eq!(modes.omega.len(), 8);
            assert!(modes.omega.windows(2).all(|pair| pair[0] <= pair[1]));
            assert_eq!(modes.shapes[0].len(), model.n_dofs());
        }
        other => panic!("{other:?}"),
    }
}

/// The engine caches by content hash: one thread or several, the bytes must be the same.
#[test]
fn results_do_not_depend_on_the_thread_count() {
    let mesh = structured::annulus(0.05, 0.12, 0.0, 0.01, [4, 40, 2], "disc");
    let (model, _) = assemble(&mesh, "inner");
    assert!(model.n_dofs() > 600, "exercise the Lanczos path");
    let run_with_threads = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let (model, _) = assemble(&mesh, "inner");
                let outputs = run_stage(&model, &[("n_modes", Value::Int(12))]).unwrap();
                (
                    Artifact::Model(Box::new(model)).encode(),
                    outputs["modes"].encode(),
                )
            })
    };
    let (model_one, modes_one) = run_with_threads(1);
    let (model_three, modes_three) = run_with_threads(3);
    assert!(model_one == model_three, "assembled model differs");
    assert!(modes_one == modes_three, "modes differ");
}

#[test]
fn empty_or_unbounded_bands_are_errors() {
    let model = cantilever(0.3, 0.03, 3, 1);
    let err = run_stage(&model, &[("n_modes", Value::Int(0))]).unwrap_err();
    assert!(err.message.contains("f_max_hz = 0"), "{err}");
    let err = run_stage(
        &model,
        &[
            ("f_max_hz", Value::Float(100.0)),
            ("shift_hz", Value::Float(200.0)),
        ],
    )
    .unwrap_err();
    assert!(err.message.contains("band is empty"), "{err}");
}

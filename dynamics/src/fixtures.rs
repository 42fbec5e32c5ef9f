//! The fixtures the dynamics' unit tests share: sliding equilibria of the brakes
//! (`squeal_model::fixtures`), and the inputs of the stages downstream.

use std::collections::BTreeMap;
use std::sync::Arc;

use squeal_model::mesh::brake::{BrakeGeometry, brake};

use crate::artifact::{Artifact, ComplexMode, ComplexModes, Equilibrium, Mesh, Model};
use crate::contact::lcp::LcpSettings;
use crate::equilibrium::{self, Load};
use crate::stability::Stability;
use crate::stage::{Input, Inputs, Params, Stage, Value};
use crate::table::{ColumnData, Table};
use crate::transient::Transient;

pub(crate) use squeal_model::fixtures::{coarse_brake, small_brake, test_model};

/// The sliding equilibrium of `model` at `mu` and `omega`, the pads pressed by an interference
/// of 50 µm (semi-smooth Newton).
pub(crate) fn sliding_equilibrium(model: &Model, mu: f64, omega: f64) -> Equilibrium {
    equilibrium::solve(
        model,
        mu,
        omega,
        Load::Interference(5e-5),
        equilibrium::Solver::SemismoothNewton,
        &LcpSettings::default(),
    )
    .unwrap()
    .0
}

/// The small brake through equilibrium and stability, as the transient's inputs.
pub(crate) fn brake_inputs() -> Inputs {
    brake_inputs_of(&BrakeGeometry::small())
}

/// A brake's model, sliding equilibrium and stability tables (modes below 8 kHz).
pub(crate) fn brake_inputs_of(geometry: &BrakeGeometry) -> Inputs {
    brake_inputs_of_mesh(&brake(geometry).unwrap())
}

/// [`brake_inputs_of`] for a brake mesh of any element kind.
pub(crate) fn brake_inputs_of_mesh(mesh: &Mesh) -> Inputs {
    let (model, _) = test_model(mesh, "hub, pad_backs", &[]);
    let equilibrium = sliding_equilibrium(&model, 0.6, 4.0);
    let model = Arc::new(Artifact::Model(Box::new(model)));
    let equilibrium = Arc::new(Artifact::Equilibrium(Box::new(equilibrium)));
    let mut inputs = Inputs(BTreeMap::from([
        ("model".to_string(), Input::One(model)),
        ("equilibrium".to_string(), Input::One(equilibrium)),
    ]));
    let stability_params = Params::defaults(&Stability, &[("f_max_hz", Value::Float(8000.0))]);
    let outputs = Stability.run(&stability_params, &inputs).unwrap();
    inputs.0.insert(
        "complex_modes".to_string(),
        Input::One(Arc::new(outputs["modes"].clone())),
    );
    inputs
}

/// The most unstable of the complex modes in `inputs` (a brake's, from [`brake_inputs`]).
pub(crate) fn most_unstable(inputs: &Inputs) -> &ComplexMode {
    let modes: &ComplexModes = inputs.get("complex_modes").unwrap();
    modes
        .modes
        .iter()
        .max_by(|a, b| a.re.total_cmp(&b.re))
        .unwrap()
}

/// The `transient` stage's parameters: its defaults, with `overrides`.
pub(crate) fn transient_params(overrides: &[(&str, Value)]) -> Params {
    Params::defaults(&Transient, overrides)
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

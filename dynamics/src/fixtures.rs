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

/// `mesh` with its node-to-node pairs spread over neighbouring face nodes, each side still
/// reading the same point: the disc side of every pair whose disc node has two neighbours on
/// the disc face along x (else y), at the face's node spacing, becomes ¼, ½, ¼ over the three;
/// with `quadratic_pads`, the pad side of every pair whose pad node has two neighbours along x
/// that are the anchors of node-to-node pairs (not themselves spread) becomes 5/3 on itself and
/// −1/3 on each neighbour, as a mid-edge node's mortar row on a quadratic face. Returns the mesh
/// and how many disc and pad sides were spread.
pub(crate) fn spread_pairs(mesh: &Mesh, quadratic_pads: bool) -> (Mesh, usize, usize) {
    let spacing = {
        let disc: Vec<[f64; 3]> = mesh
            .contact_pairs
            .iter()
            .map(|pair| pair.disc_position(&mesh.nodes))
            .collect();
        let mut spacing = f64::INFINITY;
        for (i, a) in disc.iter().enumerate() {
            for b in &disc[i + 1..] {
                spacing = spacing.min(crate::artifact::mesh::norm(crate::artifact::mesh::sub(
                    *a, *b,
                )));
            }
        }
        spacing
    };
    let find = |nodes: &[u32], x: [f64; 3]| {
        nodes.iter().copied().find(|&node| {
            let y = mesh.nodes[node as usize];
            (0..3).all(|axis| (y[axis] - x[axis]).abs() < 1e-9 * spacing)
        })
    };
    let neighbours = |nodes: &[u32], node: u32, axes: &[usize]| {
        let x = mesh.nodes[node as usize];
        axes.iter().find_map(|&axis| {
            let step = |sign: f64| {
                let mut y = x;
                y[axis] += sign * spacing;
                find(nodes, y)
            };
            step(-1.0).zip(step(1.0))
        })
    };
    let disc_face: Vec<u32> = mesh
        .contact_pairs
        .iter()
        .map(|pair| pair.disc[0].0)
        .collect();
    let pad_face: Vec<u32> = mesh
        .contact_pairs
        .iter()
        .map(|pair| pair.pad_node())
        .collect();
    let mut spread = mesh.clone();
    let (mut discs, mut pads) = (0, 0);
    for pair in &mut spread.contact_pairs {
        let disc = pair.disc[0].0;
        if let Some((a, b)) = neighbours(&disc_face, disc, &[0, 1]) {
            pair.disc = vec![(a, 0.25), (disc, 0.5), (b, 0.25)];
            discs += 1;
        }
    }
    if quadratic_pads {
        // Pad nodes with two neighbours along x, neither of which has two itself.
        let has_two = |node: u32| neighbours(&pad_face, node, &[0]).is_some();
        for pair in &mut spread.contact_pairs {
            let pad = pair.pad_node();
            if let Some((a, b)) = neighbours(&pad_face, pad, &[0])
                && !has_two(a)
                && !has_two(b)
            {
                pair.pad = vec![(pad, 5.0 / 3.0), (a, -1.0 / 3.0), (b, -1.0 / 3.0)];
                pads += 1;
            }
        }
    }
    (spread, discs, pads)
}

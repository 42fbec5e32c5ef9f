//! Sweep expansion: from the stages a study's targets need, to stage instances.
//!
//! A stage with a `matrix:` becomes one instance per point of the cartesian product of its
//! swept values. An instance inherits the sweep coordinates of its inputs: a one-artifact input
//! fed by a swept stage fans out (one instance per upstream point), and inputs sharing a swept
//! parameter are joined on it (not crossed). A many-artifact input gathers every upstream point
//! consistent with the instance's own coordinates.

use std::collections::{BTreeMap, HashMap};

use squeal_contract::{Arity, Coords, Value};

use crate::study::Study;

/// A swept parameter: stage index and parameter name.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Axis {
    pub stage: usize,
    pub param: String,
    /// `param`, or `stage.param` when two stages sweep a parameter of the same name.
    pub label: String,
}

#[derive(Debug, Clone)]
/// One connection of an instance: a port fed by one stage's output. A list port
/// ([`Arity::List`]) has one connection per stage listed, all under its name, in order.
pub struct InstanceInput {
    pub port: String,
    pub output: String,
    pub arity: Arity,
    /// Upstream instance indices: exactly one for [`Arity::One`] and [`Arity::List`].
    pub from: Vec<usize>,
}

#[derive(Debug, Clone)]
pub struct Instance {
    pub stage: usize,
    /// `stage` or `stage[mu=0.38]`.
    pub name: String,
    /// Sweep coordinates as (axis index, value), in a fixed order per stage.
    pub coords: Vec<(usize, Value)>,
    /// Every declared parameter, swept ones included.
    pub params: BTreeMap<String, Value>,
    pub inputs: Vec<InstanceInput>,
}

/// A partial instance during expansion: its coordinates and its one-input upstream instances.
type Combo = (Vec<(usize, Value)>, Vec<usize>);

/// The instances a set of targets needs, upstream before downstream.
pub struct Instances {
    pub axes: Vec<Axis>,
    pub list: Vec<Instance>,
    /// Instance indices of each stage (empty for stages no target needs).
    pub of_stage: Vec<Vec<usize>>,
}

impl Instances {
    /// Coordinates with their labels, for names, tables and stage inputs.
    pub fn labelled(&self, coords: &[(usize, Value)]) -> Coords {
        coords
            .iter()
            .map(|(axis, value)| (self.axes[*axis].label.clone(), value.clone()))
            .collect()
    }

    /// The swept path segments of an instance (`mu=0.38`), for hive-style output folders. A
    /// value's `/`, `\\` and `%` are percent-encoded (`path=meshes%2Ffine.msh`), so that each
    /// coordinate is one folder; pyarrow's and duckdb's hive partitioning decode them.
    pub fn coord_segments(&self, instance: &Instance) -> Vec<String> {
        self.labelled(&instance.coords)
            .iter()
            .map(|(label, value)| {
                let value = value
                    .to_string()
                    .replace('%', "%25")
                    .replace('/', "%2F")
                    .replace('\\', "%5C");
                format!("{label}={value}")
            })
            .collect()
    }

    pub fn expand(study: &Study, targets: &[usize]) -> Instances {
        let needed = needed_stages(study, targets);
        let axes = study_axes(study);
        let axis_of = |stage: usize, param: &str| {
            axes.iter()
                .position(|axis| axis.stage == stage && axis.param == param)
                .expect("every swept param is an axis")
        };
        let mut instances = Instances {
            axes: axes.clone(),
            list: Vec::new(),
            of_stage: vec![Vec::new(); study.stages.len()],
        };
        for stage_idx in topological_order(study) {
            if !needed[stage_idx] {
                continue;
            }
            let decl = &study.stages[stage_idx];
            // Join the one-artifact inputs on shared axes.
            let mut combos: Vec<Combo> = vec![(Vec::new(), Vec::new())];
            for input in decl
                .inputs
                .iter()
                .filter(|input| input.arity != Arity::Many)
            {
                let upstream = &instances.of_stage[input.from];
                combos = join(&instances.list, &combos, upstream);
            }
            // Then cross with this stage's own sweep.
            for (param, values) in &decl.matrix {
                let axis = axis_of(stage_idx, param);
                combos = combos
                    .into_iter()
                    .flat_map(|(coords, from)| {
                        values.iter().map(move |value| {
                            let mut coords = coords.clone();
                            coords.push((axis, value.clone()));
                            (coords, from.clone())
                        })
                    })
                    .collect();
            }
            for (coords, one_from) in combos {
                let mut params = decl.params.clone();
                for (axis, value) in &coords {
                    if axes[*axis].stage == stage_idx {
                        let param = &axes[*axis].param;
                        params.insert(param.clone(), study.swept_value(stage_idx, param, value));
                    }
                }
                let mut one_from = one_from.into_iter();
                let inputs = decl
                    .inputs
                    .iter()
                    .map(|input| {
                        let from = match input.arity {
                            Arity::One | Arity::List => {
                                vec![one_from.next().expect("one upstream per joined input")]
                            }
                            Arity::Many => instances.of_stage[input.from]
                                .iter()
                                .copied()
                                .filter(|&up| consistent(&coords, &instances.list[up].coords))
                                .collect(),
                        };
                        InstanceInput {
                            port: input.port.clone(),
                            output: input.output.clone(),
                            arity: input.arity,
                            from,
                        }
                    })
                    .collect();
                let name = if coords.is_empty() {
                    decl.name.clone()
                } else {
                    let segments: Vec<String> = coords
                        .iter()
                        .map(|(axis, value)| format!("{}={value}", axes[*axis].label))
                        .collect();
                    format!("{}[{}]", decl.name, segments.join(","))
                };
                instances.of_stage[stage_idx].push(instances.list.len());
                instances.list.push(Instance {
                    stage: stage_idx,
                    name,
                    coords,
                    params,
                    inputs,
                });
            }
        }
        instances
    }
}

/// Extends each partial combination with every upstream instance that agrees with it on the
/// axes they share. Upstream instances are indexed by those axes, so this is linear.
fn join(list: &[Instance], combos: &[Combo], upstream: &[usize]) -> Vec<Combo> {
    let (Some((first_coords, _)), Some(&first_up)) = (combos.first(), upstream.first()) else {
        return Vec::new();
    };
    let shared: Vec<usize> = list[first_up]
        .coords
        .iter()
        .map(|(axis, _)| *axis)
        .filter(|axis| first_coords.iter().any(|(own, _)| own == axis))
        .collect();
    let project = |coords: &[(usize, Value)]| -> Vec<String> {
        shared
            .iter()
            .map(|axis| {
                coords
                    .iter()
                    .find(|(own, _)| own == axis)
                    .map(|(_, value)| format!("{value:?}"))
                    .unwrap_or_default()
            })
            .collect()
    };
    let mut by_shared: HashMap<Vec<String>, Vec<usize>> = HashMap::new();
    for &up in upstream {
        by_shared
            .entry(project(&list[up].coords))
            .or_default()
            .push(up);
    }
    let mut joined = Vec::new();
    for (coords, from) in combos {
        for &up in by_shared
            .get(&project(coords))
            .map_or(&[][..], Vec::as_slice)
        {
            let mut coords = coords.clone();
            coords.extend(
                list[up]
                    .coords
                    .iter()
                    .filter(|(axis, _)| !shared.contains(axis))
                    .cloned(),
            );
            let mut from = from.clone();
            from.push(up);
            joined.push((coords, from));
        }
    }
    joined
}

/// Whether two coordinate lists agree on every axis they share.
fn consistent(a: &[(usize, Value)], b: &[(usize, Value)]) -> bool {
    a.iter().all(|(axis, value)| {
        b.iter()
            .all(|(other, other_value)| other != axis || other_value == value)
    })
}

fn study_axes(study: &Study) -> Vec<Axis> {
    let mut axes: Vec<Axis> = study
        .stages
        .iter()
        .enumerate()
        .flat_map(|(stage, decl)| {
            decl.matrix.iter().map(move |(param, _)| Axis {
                stage,
                param: param.clone(),
                label: param.clone(),
            })
        })
        .collect();
    let labels: Vec<String> = axes.iter().map(|axis| axis.param.clone()).collect();
    for axis in &mut axes {
        if labels.iter().filter(|label| **label == axis.param).count() > 1 {
            axis.label = format!("{}.{}", study.stages[axis.stage].name, axis.param);
        }
    }
    axes
}

/// Stages the targets need, transitively.
fn needed_stages(study: &Study, targets: &[usize]) -> Vec<bool> {
    let mut needed = vec![false; study.stages.len()];
    let mut stack = targets.to_vec();
    while let Some(idx) = stack.pop() {
        if !std::mem::replace(&mut needed[idx], true) {
            stack.extend(study.stages[idx].inputs.iter().map(|input| input.from));
        }
    }
    needed
}

/// Stage indices, every stage after its inputs, ties in file order. The study is acyclic.
pub fn topological_order(study: &Study) -> Vec<usize> {
    let mut pending: Vec<usize> = study
        .stages
        .iter()
        .map(|stage| stage.inputs.len())
        .collect();
    let mut dependents = vec![Vec::new(); study.stages.len()];
    for (idx, stage) in study.stages.iter().enumerate() {
        for input in &stage.inputs {
            dependents[input.from].push(idx);
        }
    }
    let mut ready: std::collections::BTreeSet<usize> = (0..pending.len())
        .filter(|&idx| pending[idx] == 0)
        .collect();
    let mut order = Vec::with_capacity(pending.len());
    while let Some(idx) = ready.pop_first() {
        order.push(idx);
        for &dependent in &dependents[idx] {
            pending[dependent] -= 1;
            if pending[dependent] == 0 {
                ready.insert(dependent);
            }
        }
    }
    order
}

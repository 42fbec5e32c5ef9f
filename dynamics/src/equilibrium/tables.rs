//! The stage's tables: one row per pair, and the summary.

use super::solve::{Load, Report};
use crate::artifact::Equilibrium;
use crate::artifact::Model;
use crate::table::Table;

/// One row per pair: where (the disc point the pair faces, Σ P_l x_l: the disc node node to
/// node), how hard, open or closed.
pub fn contact_table(model: &Model, equilibrium: &Equilibrium) -> Table {
    let pairs = &model.mesh.contact_pairs;
    let position = |axis: usize| {
        pairs
            .iter()
            .map(|pair| pair.disc_position(&model.mesh.nodes)[axis])
            .collect::<Vec<f64>>()
    };
    let r_n = equilibrium.r_n.clone();
    Table::new()
        .with("pair", (0..pairs.len() as i64).collect::<Vec<i64>>())
        .with("x", position(0))
        .with("y", position(1))
        .with("z", position(2))
        .with(
            "side",
            pairs
                .iter()
                .map(|pair| {
                    if pair.normal[2] >= 0.0 {
                        "upper"
                    } else {
                        "lower"
                    }
                    .to_string()
                })
                .collect::<Vec<String>>(),
        )
        .with("r_n", r_n.clone())
        .with(
            "r_t",
            r_n.iter().map(|r| equilibrium.mu * r).collect::<Vec<f64>>(),
        )
        .with("r_b", vec![0.0; pairs.len()])
        .with(
            "pressure",
            r_n.iter()
                .zip(pairs)
                .map(|(r, pair)| r / pair.area)
                .collect::<Vec<f64>>(),
        )
        .with("gap", equilibrium.gap.clone())
        .with("sliding_speed", equilibrium.frames.sliding_speed.clone())
        .with(
            "status",
            equilibrium
                .closed
                .iter()
                .map(|closed| if *closed { "closed" } else { "open" }.to_string())
                .collect::<Vec<String>>(),
        )
}

/// Total normal reaction on the upper (normal +z) or lower pad faces.
pub fn side_force(mesh: &crate::artifact::mesh::Mesh, r_n: &[f64], upper: bool) -> f64 {
    mesh.contact_pairs
        .iter()
        .zip(r_n)
        .filter(|(pair, _)| (pair.normal[2] >= 0.0) == upper)
        .map(|(_, r)| r)
        .sum()
}

/// The figures that say whether the solve is to be trusted, and the resultant forces.
pub(super) fn summary_table(
    equilibrium: &Equilibrium,
    report: &Report,
    mesh: &crate::artifact::mesh::Mesh,
    max_strain: f64,
) -> Table {
    let total: f64 = equilibrium.r_n.iter().sum();
    let largest = |pressures: &[super::PressureOn]| {
        pressures
            .iter()
            .map(|on| on.pressure)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let (load, mut quantities) = match (&report.load, report.applied) {
        (Load::Pressure(pressures), Some(applied)) => (
            "pressure",
            vec![
                ("pressure_Pa", largest(pressures)),
                ("pressure_force_upper_N", applied.force[0]),
                ("pressure_force_lower_N", applied.force[1]),
                ("back_area_upper_m2", applied.area[0]),
                ("back_area_lower_m2", applied.area[1]),
                ("floating_bodies", applied.floating_bodies as f64),
            ],
        ),
        (Load::Pressure(pressures), None) => {
            ("pressure", vec![("pressure_Pa", largest(pressures))])
        }
        (Load::Interference(delta), _) => ("interference", vec![("interference_m", *delta)]),
    };
    quantities.extend([
        ("iterations", report.lcp.iterations as f64),
        ("complementarity_residual", report.lcp.residual()),
        ("equation_residual", report.equation_residual),
        (
            "closed_pairs",
            equilibrium.closed.iter().filter(|closed| **closed).count() as f64,
        ),
        ("pairs", equilibrium.closed.len() as f64),
        (
            "normal_force_upper_N",
            side_force(mesh, &equilibrium.r_n, true),
        ),
        (
            "normal_force_lower_N",
            side_force(mesh, &equilibrium.r_n, false),
        ),
        ("normal_force_total_N", total),
        ("friction_force_total_N", equilibrium.mu * total),
        ("max_strain_estimate", max_strain),
    ]);
    Table::quantities(&quantities)
        .with(
            "solver",
            vec![report.solver.name().to_string(); quantities.len()],
        )
        .with("load", vec![load.to_string(); quantities.len()])
}

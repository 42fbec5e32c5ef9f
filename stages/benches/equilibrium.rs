//! Sliding equilibrium of the default brake (`mesh.brake` defaults, about 31,500 DOFs):
//! factorisation, condensation and iteration times, and the iteration counts of both solvers.
//! Run with `cargo bench -p squeal-stages --bench equilibrium`.

use squeal_stages::assemble::with_default_materials;
use squeal_stages::contact::lcp::LcpSettings;
use squeal_stages::equilibrium::{Load, Solver, solve};
use squeal_stages::mesh::brake::{BrakeGeometry, brake};

fn main() {
    let mesh = brake(&BrakeGeometry::default()).expect("default brake");
    let started = std::time::Instant::now();
    let (model, _) = with_default_materials(&mesh, "hub, pad_backs", &[]).expect("assembly");
    println!(
        "default brake: {} free DOFs, {} contact pairs; assembly {:.3} s",
        model.n_dofs(),
        mesh.contact_pairs.len(),
        started.elapsed().as_secs_f64()
    );
    println!(
        "{:<20} {:>10} {:>12} {:>12} {:>12} {:>12} {:>10}",
        "solver", "iterations", "factor s", "condense s", "iterate s", "residual", "closed"
    );
    for (name, solver, settings) in [
        (
            "semi-smooth Newton",
            Solver::SemismoothNewton,
            LcpSettings::default(),
        ),
        (
            "fixed point",
            Solver::FixedPoint,
            LcpSettings {
                relaxation: 0.5,
                max_iterations: 200_000,
                ..LcpSettings::default()
            },
        ),
    ] {
        let (equilibrium, report) = solve(
            &model,
            0.38,
            4.0,
            Load::Interference(1e-4),
            solver,
            &settings,
        )
        .expect("equilibrium");
        println!(
            "{name:<20} {:>10} {:>12.3} {:>12.3} {:>12.4} {:>12.2e} {:>10}",
            report.lcp.iterations,
            report.seconds[0],
            report.seconds[1],
            report.seconds[2],
            report.lcp.residual(),
            equilibrium.closed.iter().filter(|closed| **closed).count()
        );
    }
}

//! Coincident meshes: mortar contact reduces to node-to-node contact. The coarse brake's pads
//! are paired with the disc by `mesh.brake`'s node-to-node pairs and by `contact.mortar`; the
//! sliding equilibrium (each pair's normal force, the displacement) and the complex eigenvalues
//! below a frequency must agree to round-off.

use std::collections::HashMap;

use faer::c64;
use serde::Deserialize;
use squeal_stages::artifact::{Equilibrium, Mesh, Model};
use squeal_stages::assemble::with_default_materials;
use squeal_stages::contact::lcp::LcpSettings;
use squeal_stages::equilibrium::{self, Load, Solver};
use squeal_stages::fem::faces::Side;
use squeal_stages::mesh::brake::{BrakeGeometry, brake};
use squeal_stages::mesh::mortar_pairs::mortar_pairs;
use squeal_stages::stability::{self, Settings};

use crate::reference;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Coincident {
    mu: f64,
    interference_m: f64,
    f_max_hz: f64,
    /// |r_mortar − r_node| / max r of the worst pair.
    force_tolerance: f64,
    /// ‖u_mortar − u_node‖∞ / ‖u_node‖∞.
    displacement_tolerance: f64,
    /// |λ_mortar − λ_node| / |λ_node| of the worst eigenvalue.
    eigenvalue_tolerance: f64,
}

fn solve(mesh: &Mesh, case: &Coincident) -> (Model, Equilibrium, Vec<c64>) {
    let (model, _) = with_default_materials(mesh, "hub, pad_backs", &[]).expect("assembly");
    let (equilibrium, _) = equilibrium::solve(
        &model,
        case.mu,
        4.0,
        Load::Interference(case.interference_m),
        Solver::SemismoothNewton,
        &LcpSettings::default(),
    )
    .expect("sliding equilibrium");
    let settings = Settings {
        f_max_hz: case.f_max_hz,
        ..Settings::default()
    };
    let solution = stability::solve(&model, &equilibrium, &settings).expect("stability");
    let mut eigenvalues: Vec<c64> = solution.pairs.iter().map(|pair| pair.lambda).collect();
    eigenvalues.sort_by(|a, b| a.im.total_cmp(&b.im));
    (model, equilibrium, eigenvalues)
}

#[test]
fn mortar_pairs_of_coincident_faces_give_the_node_to_node_equilibrium_and_eigenvalues() {
    let case: Coincident = reference::load("coincident_mortar");
    let conforming = brake(&BrakeGeometry::coarse()).expect("mesh");
    let mut mortar = conforming.clone();
    let side = |name: &'static str| Side::new(name, conforming.node_sets[name].iter().copied());
    let (pairs, coverage) = mortar_pairs(
        &conforming,
        &side("contact_disc"),
        &side("contact_pad"),
        1e-3,
    )
    .expect("mortar pairs");
    assert!((coverage.covered - 1.0).abs() < 1e-12, "{coverage:?}");
    mortar.contact_pairs = pairs;

    let (model, by_node, node_eigenvalues) = solve(&conforming, &case);
    let (_, by_mortar, mortar_eigenvalues) = solve(&mortar, &case);

    // Pairs are matched by their pad node (the orders differ).
    let mortar_pair_of: HashMap<u32, usize> = mortar
        .contact_pairs
        .iter()
        .enumerate()
        .map(|(index, pair)| (pair.pad[0].0, index))
        .collect();
    let largest_force = by_node.r_n.iter().copied().fold(0.0, f64::max);
    let mut worst_force: f64 = 0.0;
    for (index, pair) in conforming.contact_pairs.iter().enumerate() {
        let other = mortar_pair_of[&pair.pad[0].0];
        assert_eq!(by_node.closed[index], by_mortar.closed[other]);
        worst_force =
            worst_force.max((by_node.r_n[index] - by_mortar.r_n[other]).abs() / largest_force);
    }
    assert!(
        worst_force <= case.force_tolerance,
        "forces differ by {worst_force:e}"
    );

    let largest_u = by_node.u.iter().fold(0.0f64, |m, u| m.max(u.abs()));
    let worst_u = by_node
        .u
        .iter()
        .zip(&by_mortar.u)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
        / largest_u;
    assert!(
        worst_u <= case.displacement_tolerance,
        "displacements differ by {worst_u:e}"
    );

    assert_eq!(node_eigenvalues.len(), mortar_eigenvalues.len());
    let worst_lambda = node_eigenvalues
        .iter()
        .zip(&mortar_eigenvalues)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).norm() / a.norm()));
    assert!(
        worst_lambda <= case.eigenvalue_tolerance,
        "eigenvalues differ by {worst_lambda:e}"
    );
    eprintln!(
        "{} DOFs, {} pairs: forces within {worst_force:.1e}, displacements {worst_u:.1e}, {} eigenvalues {worst_lambda:.1e}",
        model.n_dofs(),
        conforming.contact_pairs.len(),
        node_eigenvalues.len()
    );
}

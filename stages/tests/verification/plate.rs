//! Annular plate, clamped inside and free outside: the frequencies of the modes with 0 to 4
//! nodal diameters against Kirchhoff plate theory, in hexahedra and in every element kind.

use serde::Deserialize;
use squeal_stages::artifact::mesh::Mesh;
use squeal_stages::artifact::{ElementKind, Model};
use squeal_stages::assemble::with_default_materials;
use squeal_stages::mesh::{convert, structured};

use crate::real_modes::{STEEL_E, STEEL_RHO, check_residuals_and_normalisation, lowest};
use crate::reference;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Plate {
    outer_radius_m: f64,
    inner_radius_m: f64,
    thickness_m: f64,
    poisson: f64,
    /// Hexahedra (radial, angular, through the thickness) of each mesh tried.
    meshes: Vec<[usize; 3]>,
    /// Frequency parameter λ² = ω a² √(ρh/D) of the lowest mode with n nodal diameters,
    /// n = 0, 1, 2, …
    lambda_squared: Vec<f64>,
    /// |ω − ω_Kirchhoff| / ω_Kirchhoff.
    tolerance: f64,
}

/// Number of nodal diameters of a plate mode: the dominant Fourier harmonic of the
/// out-of-plane displacement around the outer rim (top face).
fn nodal_diameters(model: &Model, mesh: &Mesh, shape: &[f64], max_n: usize) -> usize {
    let rim: Vec<u32> = mesh.node_sets["outer"]
        .iter()
        .copied()
        .filter(|node| mesh.node_sets["top"].binary_search(node).is_ok())
        .collect();
    let samples: Vec<(f64, f64)> = rim
        .iter()
        .map(|&node| {
            let [x, y, _] = mesh.nodes[node as usize];
            let w = model.dof_of_node[node as usize][2].map_or(0.0, |dof| shape[dof as usize]);
            (y.atan2(x), w)
        })
        .collect();
    // Amplitude of harmonic n: |Σ w| / N for n = 0, 2 |Σ w e^{inθ}| / N otherwise.
    let amplitude = |n: usize| {
        let (c, s) = samples.iter().fold((0.0, 0.0), |(c, s), (theta, w)| {
            (
                c + w * (n as f64 * theta).cos(),
                s + w * (n as f64 * theta).sin(),
            )
        });
        let factor = if n == 0 { 1.0 } else { 2.0 };
        factor * (c * c + s * s).sqrt() / samples.len() as f64
    };
    (0..=max_n)
        .max_by(|&m, &n| amplitude(m).total_cmp(&amplitude(n)))
        .unwrap_or(0)
}

/// Each of the lowest modes with up to `max_n` nodal diameters (n = 0 once, every n ≥ 1 as a
/// repeated pair) of the plate meshed with `counts` cells as elements of `kind`: its number of
/// nodal diameters (up to `2 max_n`) and ω (rad/s).
fn plate_modes(case: &Plate, kind: ElementKind, counts: [usize; 3]) -> Vec<(usize, f64)> {
    let (a, b, h) = (case.outer_radius_m, case.inner_radius_m, case.thickness_m);
    let max_n = case.lambda_squared.len() - 1;
    let mesh = convert::as_kind(&structured::annulus(b, a, 0.0, h, counts, "disc"), kind);
    let (model, _) =
        with_default_materials(&mesh, "inner", &[("nu_disc", case.poisson)]).expect("assembly");
    let solution = lowest(&model, 2 * max_n + 1);
    check_residuals_and_normalisation(&model, &solution);
    (0..solution.lambda.len())
        .map(|mode| {
            let shape: Vec<f64> = solution.shapes.col(mode).iter().copied().collect();
            let n = nodal_diameters(&model, &mesh, &shape, 2 * max_n);
            (n, solution.lambda[mode].sqrt())
        })
        .collect()
}

/// Kirchhoff's ω (rad/s) of the lowest mode with `n` nodal diameters.
fn kirchhoff(case: &Plate, n: usize) -> f64 {
    let (a, h, nu) = (case.outer_radius_m, case.thickness_m, case.poisson);
    let rigidity = STEEL_E * h.powi(3) / (12.0 * (1.0 - nu * nu));
    case.lambda_squared[n] / (a * a) * (rigidity / (STEEL_RHO * h)).sqrt()
}

#[test]
fn annular_plate_matches_kirchhoff_theory() {
    let case: Plate = reference::load("annular_plate");
    let max_n = case.lambda_squared.len() - 1;
    for &counts in &case.meshes {
        let mut seen = vec![0usize; max_n + 1];
        for (mode, (n, omega)) in plate_modes(&case, ElementKind::Hex8, counts)
            .into_iter()
            .enumerate()
        {
            assert!(
                n <= max_n,
                "{counts:?}: mode {mode} has {n} nodal diameters"
            );
            seen[n] += 1;
            let exact = kirchhoff(&case, n);
            let error = (omega - exact).abs() / exact;
            assert!(
                error < case.tolerance,
                "{counts:?}: mode {mode}, n = {n}: omega = {omega}, Kirchhoff {exact} ({:.2} %)",
                100.0 * error
            );
        }
        let mut expected = vec![2; max_n + 1];
        expected[0] = 1;
        assert_eq!(seen, expected, "{counts:?}");
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PlateByKind {
    /// Hexahedral cells of the meshes, each kind made from them (split, mid-edge nodes).
    meshes: Vec<[usize; 3]>,
    /// Largest |ω − ω_Kirchhoff| / ω_Kirchhoff over the modes on each mesh, by kind name.
    tolerances: std::collections::BTreeMap<String, Vec<f64>>,
}

/// The largest relative difference from Kirchhoff theory over the lowest modes with 0 to
/// `max_n` nodal diameters, on the plate meshed with `counts` cells as elements of `kind`.
fn worst_error_against_kirchhoff(case: &Plate, kind: ElementKind, counts: [usize; 3]) -> f64 {
    let max_n = case.lambda_squared.len() - 1;
    plate_modes(case, kind, counts)
        .into_iter()
        .map(|(n, omega)| {
            let exact = kirchhoff(case, n.min(max_n));
            (omega - exact).abs() / exact
        })
        .fold(0.0, f64::max)
}

#[test]
fn every_element_kind_approaches_kirchhoff_theory_on_the_annular_plate() {
    let case: Plate = reference::load("annular_plate");
    let by_kind: PlateByKind = reference::load("annular_plate_by_kind");
    for kind in ElementKind::ALL {
        let tolerances = &by_kind.tolerances[kind.name()];
        let errors: Vec<f64> = by_kind
            .meshes
            .iter()
            .map(|&counts| worst_error_against_kirchhoff(&case, kind, counts))
            .collect();
        for ((error, tolerance), counts) in errors.iter().zip(tolerances).zip(&by_kind.meshes) {
            assert!(
                error < tolerance,
                "{kind} on {counts:?}: {:.2} % from Kirchhoff (tolerance {:.2} %; all meshes {errors:?})",
                100.0 * error,
                100.0 * tolerance
            );
        }
        assert!(
            errors.windows(2).all(|pair| pair[1] < pair[0]),
            "{kind}: the error does not fall as the mesh is refined: {errors:?}"
        );
    }
}

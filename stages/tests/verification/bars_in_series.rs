//! Sliding equilibrium of two bars in contact, pressed together by an interference: the
//! contact force of two springs in series.

use serde::Deserialize;
use squeal_stages::assemble::with_default_materials;
use squeal_stages::contact::lcp::LcpSettings;
use squeal_stages::equilibrium::{Load, Solver, solve};
use squeal_stages::mesh::structured::stacked_blocks;

use crate::reference;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Bars {
    width_m: f64,
    disc_length_m: f64,
    pad_length_m: f64,
    disc_young_pa: f64,
    pad_young_pa: f64,
    interference_m: f64,
    /// Total normal force against δ / (L₁/(E₁A) + L₂/(E₂A)), relative.
    force_tolerance: f64,
    /// Each pair's pressure r/a against F/A, relative.
    pressure_tolerance: f64,
}

/// Two blocks in series, pressed by an interference, with ν = 0 so that the stress is
/// uniaxial: F = δ / (L₁/(E₁A) + L₂/(E₂A)), carried as a uniform pressure.
#[test]
fn two_bars_in_contact_match_the_series_spring_formula() {
    let case: Bars = reference::load("bars_in_series");
    let mesh = stacked_blocks(case.width_m, case.disc_length_m, case.pad_length_m);
    let (model, _) = with_default_materials(
        &mesh,
        "base, pad_backs",
        &[
            ("nu_disc", 0.0),
            ("nu_pad", 0.0),
            ("E_disc", case.disc_young_pa),
            ("E_pad", case.pad_young_pa),
        ],
    )
    .expect("assembly");
    let (equilibrium, _) = solve(
        &model,
        0.0,
        4.0,
        Load::Interference(case.interference_m),
        Solver::SemismoothNewton,
        &LcpSettings::default(),
    )
    .expect("equilibrium");
    let area = case.width_m * case.width_m;
    let expected = case.interference_m
        / (case.disc_length_m / (case.disc_young_pa * area)
            + case.pad_length_m / (case.pad_young_pa * area));
    let total: f64 = equilibrium.r_n.iter().sum();
    assert!(
        (total - expected).abs() <= case.force_tolerance * expected,
        "{total} vs {expected}"
    );
    for (r, pair) in equilibrium.r_n.iter().zip(&mesh.contact_pairs) {
        assert!(
            (r / pair.area - expected / area).abs() <= case.pressure_tolerance * expected / area,
            "pressure {} vs {}",
            r / pair.area,
            expected / area
        );
    }
}

use std::collections::BTreeMap;

use super::*;
use crate::artifact::Equilibrium;
use crate::artifact::Material;
use crate::artifact::mesh::Mesh;
use crate::fixtures::{coarse_brake, test_model};
use crate::mesh::structured::stacked_blocks;
use crate::stage::Value;

#[test]
fn the_strain_estimate_is_exact_for_a_homogeneous_strain() {
    // A distorted block under u = (a x + b y, c z, 0): ε_xx = a, ε_xy = b/2, ε_yz = c/2.
    let mut mesh = crate::mesh::structured::block([1.0, 0.5, 0.3], [3, 2, 2], "disc");
    for node in &mut mesh.nodes {
        node[0] += 0.1 * node[1] * node[2];
    }
    let (model, _) = test_model(&mesh, "", &[]);
    let (a, b, c) = (1e-3, -6e-3, 4e-3);
    let mut u = vec![0.0; model.n_dofs()];
    for (node, dofs) in model.dof_of_node.iter().enumerate() {
        let [x, y, z] = mesh.nodes[node];
        for (axis, value) in [a * x + b * y, c * z, 0.0].into_iter().enumerate() {
            u[dofs[axis].unwrap() as usize] = value;
        }
    }
    let (strain, _) = largest_strain(&model, &u);
    assert!((strain - 3e-3).abs() < 1e-15, "{strain}");
}

/// `assemble` with default materials (optionally overridden) and `clamped`.
fn model(mesh: &Mesh, clamped: &str, overrides: &[(&str, f64)]) -> Model {
    test_model(mesh, clamped, overrides).0
}

fn settings() -> LcpSettings {
    LcpSettings::default()
}

#[test]
fn contact_forces_balance_the_support_reactions_of_each_pad() {
    let mesh = coarse_brake();
    let (model, params) = test_model(&mesh, "hub, pad_backs", &[]);
    let materials: Vec<Material> = (model.mesh.parts.iter())
        .map(|part| params.material(part).unwrap())
        .collect();
    let (equilibrium, report) = solve(
        &model,
        0.38,
        4.0,
        Load::Interference(5e-5),
        Solver::SemismoothNewton,
        &settings(),
    )
    .unwrap();
    let side = |upper: bool| side_force(&mesh, &equilibrium.r_n, upper);
    let upper_back = back_reactions(&model, &materials, &equilibrium.u, "pad_backs_upper").unwrap();
    let lower_back = back_reactions(&model, &materials, &equilibrium.u, "pad_backs_lower").unwrap();
    // Each pad: contact pushes it away from the disc, its back support pushes it back.
    assert!(
        (upper_back[2] + side(true)).abs() <= 1e-10 * side(true),
        "{upper_back:?} vs {}",
        side(true)
    );
    assert!(
        (lower_back[2] - side(false)).abs() <= 1e-10 * side(false),
        "{lower_back:?} vs {}",
        side(false)
    );
    // Friction μ Σr_n along the sliding directions is carried by the backs too.
    let friction: [f64; 3] = std::array::from_fn(|axis| {
        equilibrium
            .r_n
            .iter()
            .zip(&equilibrium.frames.t)
            .zip(&mesh.contact_pairs)
            .filter(|(_, pair)| pair.normal[2] > 0.0)
            .map(|((r, t), _)| 0.38 * r * t[axis])
            .sum()
    });
    for axis in 0..2 {
        assert!(
            (upper_back[axis] + friction[axis]).abs() <= 1e-9 * side(true),
            "axis {axis}: {upper_back:?} vs {friction:?}"
        );
    }
    assert!(
        report.equation_residual <= 1e-10,
        "{}",
        report.equation_residual
    );
    assert!(report.lcp.residual() <= 1e-10);
    for (r, g) in equilibrium.r_n.iter().zip(&equilibrium.gap) {
        assert!(*r >= 0.0);
        assert!(*g >= -1e-12 * 5e-5, "penetration {g}");
    }
    assert!(equilibrium.closed.iter().any(|closed| *closed));
}

#[test]
fn without_friction_both_pads_carry_the_same_load() {
    let mesh = coarse_brake();
    let model = model(&mesh, "hub, pad_backs", &[]);
    let (equilibrium, _) = solve(
        &model,
        0.0,
        4.0,
        Load::Interference(5e-5),
        Solver::SemismoothNewton,
        &settings(),
    )
    .unwrap();
    let side = |upper: bool| side_force(&mesh, &equilibrium.r_n, upper);
    let (upper, lower) = (side(true), side(false));
    assert!(upper > 0.0);
    assert!(
        (upper - lower).abs() <= 1e-8 * upper,
        "upper {upper} lower {lower}"
    );
    // With friction the symmetry breaks: the drag tilts the pads.
    let (with_friction, _) = solve(
        &model,
        0.38,
        4.0,
        Load::Interference(5e-5),
        Solver::SemismoothNewton,
        &settings(),
    )
    .unwrap();
    assert_ne!(with_friction.r_n, equilibrium.r_n);
}

#[test]
fn fixed_point_and_newton_agree() {
    let mesh = coarse_brake();
    let model = model(&mesh, "hub, pad_backs", &[]);
    let load = 5e-5;
    let (newton, newton_report) = solve(
        &model,
        0.38,
        4.0,
        Load::Interference(load),
        Solver::SemismoothNewton,
        &settings(),
    )
    .unwrap();
    let relaxed = LcpSettings {
        relaxation: 0.5,
        max_iterations: 100_000,
        ..settings()
    };
    let (fixed, fixed_report) = solve(
        &model,
        0.38,
        4.0,
        Load::Interference(load),
        Solver::FixedPoint,
        &relaxed,
    )
    .unwrap();
    let largest = newton.r_n.iter().fold(0.0f64, |max, r| max.max(*r));
    for (a, b) in newton.r_n.iter().zip(&fixed.r_n) {
        assert!((a - b).abs() <= 1e-8 * largest, "{a} vs {b}");
    }
    assert!(newton_report.lcp.iterations < fixed_report.lcp.iterations);
}

#[test]
fn unsupported_pads_are_an_error() {
    let mesh = coarse_brake();
    let model = model(&mesh, "hub", &[]);
    let err = solve(
        &model,
        0.38,
        4.0,
        Load::Interference(5e-5),
        Solver::SemismoothNewton,
        &settings(),
    )
    .unwrap_err();
    assert!(
        err.message.contains("not positive definite") || err.message.contains("unstable"),
        "{}",
        err.message
    );
}

const PRESSURE: f64 = 1e6;

/// The coarse brake guided in-plane at its backs, pressed by `PRESSURE`.
fn pressed(
    model: &Model,
    mu: f64,
    solver: Solver,
    settings: &LcpSettings,
) -> (Equilibrium, Report) {
    solve(
        model,
        mu,
        4.0,
        Load::on_pad_backs(PRESSURE),
        solver,
        settings,
    )
    .unwrap()
}

/// Contact area per side from the mesh's tributary areas: a puck is a prism, so its back
/// has the area of its friction face.
fn pad_area(mesh: &Mesh, upper: bool) -> f64 {
    mesh.contact_pairs
        .iter()
        .filter(|pair| (pair.normal[2] >= 0.0) == upper)
        .map(|pair| pair.area)
        .sum()
}

#[test]
fn under_a_pressure_each_pad_carries_the_pressure_times_its_back_area() {
    let mesh = coarse_brake();
    let model = model(&mesh, "hub, pad_backs:xy", &[]);
    let mu = 0.38;
    let (equilibrium, report) = pressed(&model, mu, Solver::SemismoothNewton, &settings());
    let applied = report.applied.unwrap();
    // 2 pucks per pad, each free to translate along z and tilt about x and y.
    assert_eq!(applied.floating_bodies, 4);
    assert_eq!(report.lcp.a.len(), 12);
    for (side, upper) in [(0, true), (1, false)] {
        let expected = PRESSURE * pad_area(&mesh, upper);
        let contact = side_force(&mesh, &equilibrium.r_n, upper);
        eprintln!(
            "side {side}: contact {contact:.12e} N, p A {expected:.12e} N, relative {:.2e}",
            (contact - expected).abs() / expected
        );
        assert!((contact - expected).abs() <= 1e-10 * expected);
        assert!((applied.force[side] - expected).abs() <= 1e-12 * expected);
        assert!((applied.area[side] - pad_area(&mesh, upper)).abs() <= 1e-14);
    }
    // The contact forces, read back from K u − F at the pad nodes: normal r_n, along the
    // sliding direction μ r_n, none across it.
    let load = floating::pressure_load(&model, PRESSURE, PRESSURE_SET).unwrap();
    let Ku = model.K.mul_vec(&equilibrium.u);
    let largest = equilibrium.r_n.iter().fold(0.0f64, |max, r| max.max(*r));
    let mut worst_ratio = 0.0f64;
    for (pair_idx, pair) in mesh.contact_pairs.iter().enumerate() {
        let dofs = model.dof_of_node[pair.pad_node() as usize];
        let force: [f64; 3] = std::array::from_fn(|axis| {
            dofs[axis].map_or(0.0, |dof| Ku[dof as usize] - load.forces[dof as usize])
        });
        let along = |direction: [f64; 3]| crate::artifact::mesh::dot(force, direction);
        let r_n = equilibrium.r_n[pair_idx];
        assert!((along(equilibrium.frames.n[pair_idx]) - r_n).abs() <= 1e-9 * largest);
        let coulomb = (along(equilibrium.frames.t[pair_idx]) - mu * r_n).abs() / largest;
        worst_ratio = worst_ratio.max(coulomb);
        assert!(along(equilibrium.frames.b[pair_idx]).abs() <= 1e-9 * largest);
    }
    eprintln!(
        "|r_t - mu r_n| / max r_n = {worst_ratio:.2e}, equation residual {:.2e}, complementarity {:.2e}, {} iterations",
        report.equation_residual,
        report.lcp.residual(),
        report.lcp.iterations
    );
    assert!(worst_ratio <= 1e-9);
    assert!(
        report.equation_residual <= 1e-10,
        "{}",
        report.equation_residual
    );
    assert!(report.lcp.residual() <= 1e-10);
    // Penetration within roundoff of the displacements.
    let displacement = equilibrium.u.iter().fold(0.0f64, |max, u| max.max(u.abs()));
    let deepest = equilibrium.gap.iter().fold(0.0f64, |min, g| min.min(*g));
    eprintln!("deepest penetration {deepest:.2e} m, largest displacement {displacement:.2e} m");
    assert!(deepest >= -1e-10 * displacement, "penetration {deepest}");
    assert!(equilibrium.r_n.iter().all(|r| *r >= 0.0));
    assert!(equilibrium.closed.iter().any(|closed| *closed));
}

#[test]
fn without_friction_under_a_pressure_the_pads_are_mirror_images() {
    let mesh = coarse_brake();
    let model = model(&mesh, "hub, pad_backs:xy", &[]);
    let (equilibrium, _) = pressed(&model, 0.0, Solver::SemismoothNewton, &settings());
    let largest = equilibrium.r_n.iter().fold(0.0f64, |max, r| max.max(*r));
    let position = |pair: &crate::artifact::mesh::ContactPair| pair.disc_position(&mesh.nodes);
    let mut worst = 0.0f64;
    for (upper_idx, upper) in mesh.contact_pairs.iter().enumerate() {
        if upper.normal[2] < 0.0 {
            continue;
        }
        let x = position(upper);
        let lower_idx = mesh
            .contact_pairs
            .iter()
            .position(|pair| {
                pair.normal[2] < 0.0 && position(pair)[0] == x[0] && position(pair)[1] == x[1]
            })
            .expect("every upper pair has a mirror");
        worst =
            worst.max((equilibrium.r_n[upper_idx] - equilibrium.r_n[lower_idx]).abs() / largest);
    }
    eprintln!("mirror asymmetry of r_n: {worst:.2e} of the largest");
    assert!(worst <= 1e-8);
    assert!(
        (side_force(&mesh, &equilibrium.r_n, true) - side_force(&mesh, &equilibrium.r_n, false))
            .abs()
            <= 1e-10 * side_force(&mesh, &equilibrium.r_n, true)
    );
}

#[test]
fn fixed_point_and_newton_agree_under_a_pressure() {
    let mesh = coarse_brake();
    let model = model(&mesh, "hub, pad_backs:xy", &[]);
    let (newton, newton_report) = pressed(&model, 0.38, Solver::SemismoothNewton, &settings());
    let relaxed = LcpSettings {
        relaxation: 0.5,
        max_iterations: 100_000,
        ..settings()
    };
    let (fixed, fixed_report) = pressed(&model, 0.38, Solver::FixedPoint, &relaxed);
    let largest = newton.r_n.iter().fold(0.0f64, |max, r| max.max(*r));
    let worst = newton
        .r_n
        .iter()
        .zip(&fixed.r_n)
        .map(|(a, b)| (a - b).abs() / largest)
        .fold(0.0, f64::max);
    eprintln!(
        "newton {} iterations, fixed point {} iterations, |r_newton - r_fixed| / max r = {worst:.2e}",
        newton_report.lcp.iterations, fixed_report.lcp.iterations
    );
    assert!(worst <= 1e-8);
    assert!(newton_report.lcp.iterations < fixed_report.lcp.iterations);
}

/// Two blocks, the pad pressed by p on its back and guided in-plane, ν = 0: the stress is
/// −p everywhere, so the contact pressure is p and each block shortens by p L / E.
#[test]
fn two_blocks_pressed_by_a_pressure_match_the_uniaxial_solution() {
    let (width, l_disc, l_pad) = (0.02, 0.03, 0.01);
    let mesh = stacked_blocks(width, l_disc, l_pad);
    let (e_disc, e_pad) = (2.0e11, 3.0e8);
    let model = model(
        &mesh,
        "base, pad_backs:xy",
        &[
            ("nu_disc", 0.0),
            ("nu_pad", 0.0),
            ("E_disc", e_disc),
            ("E_pad", e_pad),
        ],
    );
    let pressure = 2e6;
    // Jacobi on a pad whose pairs all move together needs the damped step; it converges
    // linearly, so a tighter residual for the 1e-9 check.
    let relaxed = LcpSettings {
        relaxation: 0.5,
        max_iterations: 100_000,
        tolerance: 1e-13,
    };
    for (solver, settings) in [
        (Solver::SemismoothNewton, settings()),
        (Solver::FixedPoint, relaxed),
    ] {
        let (equilibrium, report) = solve(
            &model,
            0.0,
            4.0,
            Load::on_pad_backs(pressure),
            solver,
            &settings,
        )
        .unwrap();
        let mut worst_pressure = 0.0f64;
        for (r, pair) in equilibrium.r_n.iter().zip(&mesh.contact_pairs) {
            worst_pressure = worst_pressure.max((r / pair.area - pressure).abs() / pressure);
        }
        let u_z = |node: u32| equilibrium.u[model.dof_of_node[node as usize][2].unwrap() as usize];
        let disc_top = -pressure * l_disc / e_disc;
        let back = disc_top - pressure * l_pad / e_pad;
        let mut worst_displacement = 0.0f64;
        for pair in &mesh.contact_pairs {
            worst_displacement =
                worst_displacement.max((u_z(pair.disc[0].0) - disc_top).abs() / disc_top.abs());
        }
        for &node in &mesh.node_sets[PRESSURE_SET] {
            worst_displacement = worst_displacement.max((u_z(node) - back).abs() / back.abs());
        }
        eprintln!(
            "{solver:?}: contact pressure error {worst_pressure:.2e}, displacement error {worst_displacement:.2e}, {} iterations",
            report.lcp.iterations
        );
        assert!(worst_pressure <= 1e-9);
        assert!(worst_displacement <= 1e-9);
    }
}

/// The two blocks of the uniaxial test with the disc side of every pair that can be spread
/// read as ¼, ½, ¼ of three disc face nodes (the same point, as a finer disc mesh's mortar row
/// would). The total normal force is p A to round-off. Each pair's force is that of the
/// node-to-node pairs up to the disc face's own unevenness under the loads the weights spread:
/// about (E_pad / E_disc)(cell / l_pad), 1.5e-3 here, so within 2e-3 of the largest; with a
/// disc a thousand times stiffer the difference falls a thousandfold.
#[test]
fn pairs_weighted_over_the_disc_face_carry_the_forces_of_the_node_to_node_pairs() {
    let (width, l_disc, l_pad) = (0.02, 0.03, 0.01);
    let mesh = stacked_blocks(width, l_disc, l_pad);
    let (weighted, discs, _) = crate::fixtures::spread_pairs(&mesh, false);
    // The centre node along x and the four mid-edge nodes of the 3 × 3 face.
    assert_eq!(discs, 5);
    let pressure = 2e6;
    let applied = pressure * width * width;
    let total = |r_n: &[f64]| r_n.iter().sum::<f64>();
    for (e_disc, tolerance) in [(2.0e11, 2e-3), (2.0e14, 2e-6)] {
        let overrides = [
            ("nu_disc", 0.0),
            ("nu_pad", 0.0),
            ("E_disc", e_disc),
            ("E_pad", 3.0e8),
        ];
        let solved = |mesh: &Mesh| {
            let model = model(mesh, "base, pad_backs:xy", &overrides);
            let (equilibrium, _) = solve(
                &model,
                0.0,
                4.0,
                Load::on_pad_backs(pressure),
                Solver::SemismoothNewton,
                &settings(),
            )
            .unwrap();
            equilibrium
        };
        let (node_to_node, spread) = (solved(&mesh), solved(&weighted));
        let largest = node_to_node.r_n.iter().fold(0.0f64, |max, r| max.max(*r));
        let worst = node_to_node
            .r_n
            .iter()
            .zip(&spread.r_n)
            .map(|(a, b)| (a - b).abs() / largest)
            .fold(0.0f64, f64::max);
        eprintln!(
            "E_disc {e_disc:e}: largest difference of r_n {worst:.2e} of the largest; totals {:.12e} and {:.12e} N, p A = {applied:.12e} N",
            total(&node_to_node.r_n),
            total(&spread.r_n)
        );
        assert!(worst <= tolerance, "{worst:e}");
        assert!((total(&spread.r_n) - applied).abs() <= 1e-9 * applied);
        assert!(spread.closed.iter().all(|closed| *closed));
    }
}

#[test]
fn a_pressure_on_fully_clamped_backs_is_an_error() {
    let mesh = coarse_brake();
    let model = model(&mesh, "hub, pad_backs", &[]);
    let err = solve(
        &model,
        0.38,
        4.0,
        Load::on_pad_backs(PRESSURE),
        Solver::SemismoothNewton,
        &settings(),
    )
    .unwrap_err();
    assert!(err.message.contains("pad_backs:xy"), "{}", err.message);
    // Backs held along z only where the pressure acts, but a puck left floating in-plane.
    let model = model_with_pucks_free_in_plane(&mesh);
    let err = solve(
        &model,
        0.38,
        4.0,
        Load::on_pad_backs(PRESSURE),
        Solver::SemismoothNewton,
        &settings(),
    )
    .unwrap_err();
    assert!(err.message.contains("pad_backs:xy"), "{}", err.message);
}

/// Backs clamped along z only: the pressure falls on the supports.
fn model_with_pucks_free_in_plane(mesh: &Mesh) -> Model {
    model(mesh, "hub, pad_backs:z", &[])
}

#[test]
fn a_nonconverging_solver_under_a_pressure_reports_its_residual_history() {
    let mesh = coarse_brake();
    let model = model(&mesh, "hub, pad_backs:xy", &[]);
    let few = LcpSettings {
        max_iterations: 3,
        relaxation: 0.5,
        ..settings()
    };
    let err = solve(
        &model,
        0.38,
        4.0,
        Load::on_pad_backs(PRESSURE),
        Solver::FixedPoint,
        &few,
    )
    .unwrap_err();
    assert!(
        err.message
            .starts_with("fixed point did not converge in 3 iterations"),
        "{}",
        err.message
    );
    assert!(err.message.contains("last residuals:"), "{}", err.message);
}

/// The engine keys downstream stages by output bytes: the equilibrium must not depend on
/// how many threads computed it, under either load.
#[test]
fn equilibrium_results_do_not_depend_on_the_thread_count() {
    use crate::stage::Input;
    use std::sync::Arc;
    squeal_linalg::fix_global_parallelism();
    let mesh = coarse_brake();
    for (clamped, load) in [
        ("hub, pad_backs", "interference"),
        ("hub, pad_backs:xy", "pressure"),
    ] {
        let model = model(&mesh, clamped, &[]);
        let params = Params::defaults(&SlidingEquilibrium, &[("load", Value::Str(load.into()))]);
        let inputs = Inputs(BTreeMap::from([(
            "model".to_string(),
            Input::One(Arc::new(Artifact::Model(Box::new(model)))),
        )]));
        crate::stage::assert_outputs_independent_of_threads(
            &SlidingEquilibrium,
            &params,
            &inputs,
            load,
        );
    }
}

/// The stage itself with `load: pressure` (the two lines a study adds: `clamped: "hub,
/// pad_backs:xy"` on `assemble`, `load: pressure` on `equilibrium`).
#[test]
fn the_stage_runs_with_a_pressure_load() {
    use crate::stage::Input;
    use std::sync::Arc;
    let mesh = coarse_brake();
    let model = model(&mesh, "hub, pad_backs:xy", &[]);
    let params = Params::defaults(
        &SlidingEquilibrium,
        &[
            ("load", Value::Str("pressure".into())),
            ("pressure", Value::Float(2e6)),
        ],
    );
    let inputs = Inputs(BTreeMap::from([(
        "model".to_string(),
        Input::One(Arc::new(Artifact::Model(Box::new(model)))),
    )]));
    let outputs = SlidingEquilibrium.run(&params, &inputs).unwrap();
    let summary = outputs["summary"].as_table().unwrap();
    let Some(crate::table::ColumnData::Str(names)) = summary.column("quantity") else {
        panic!("no quantity column")
    };
    let Some(crate::table::ColumnData::F64(values)) = summary.column("value") else {
        panic!("no value column")
    };
    let value = |name: &str| values[names.iter().position(|n| n == name).unwrap()];
    assert_eq!(value("pressure_Pa"), 2e6);
    for side in ["upper", "lower"] {
        let applied = value(&format!("pressure_force_{side}_N"));
        let contact = value(&format!("normal_force_{side}_N"));
        assert!(
            (applied - contact).abs() <= 1e-10 * applied,
            "{side}: {applied} vs {contact}"
        );
        assert!((applied - 2e6 * value(&format!("back_area_{side}_m2"))).abs() <= 1e-12 * applied);
    }
    assert_eq!(value("floating_bodies"), 4.0);
    let Some(crate::table::ColumnData::Str(load)) = summary.column("load") else {
        panic!("no load column")
    };
    assert!(load.iter().all(|load| load == "pressure"));
    assert!(matches!(outputs["equilibrium"], Artifact::Equilibrium(_)));
}

/// The pad backs split into two node sets, the upper and the lower pads', each pressed by its
/// own pressure: each pad carries its own pressure times its back area, and with equal
/// pressures the equilibrium is the one of the single set.
#[test]
fn several_face_sets_carry_their_own_pressures() {
    let mut mesh = coarse_brake();
    let (upper, lower): (Vec<u32>, Vec<u32>) = mesh.node_sets[PRESSURE_SET]
        .iter()
        .partition(|&&node| mesh.nodes[node as usize][2] > 0.0);
    mesh.node_sets.insert("upper_backs".into(), upper);
    mesh.node_sets.insert("lower_backs".into(), lower);
    let model = model(&mesh, "hub, pad_backs:xy", &[]);
    let split = |upper: f64, lower: f64| {
        Load::Pressure(vec![
            PressureOn {
                set: "upper_backs".into(),
                pressure: upper,
            },
            PressureOn {
                set: "lower_backs".into(),
                pressure: lower,
            },
        ])
    };
    let solve_with = |load: Load| {
        solve(
            &model,
            0.38,
            4.0,
            load,
            Solver::SemismoothNewton,
            &settings(),
        )
        .unwrap()
    };
    let (single, _) = solve_with(Load::on_pad_backs(PRESSURE));
    let (both, _) = solve_with(split(PRESSURE, PRESSURE));
    let scale = single.r_n.iter().fold(0.0f64, |m, r| m.max(r.abs()));
    for (a, b) in single.r_n.iter().zip(&both.r_n) {
        assert!((a - b).abs() <= 1e-10 * scale, "{a} vs {b}");
    }
    let (uneven, report) = solve_with(split(PRESSURE, 2.0 * PRESSURE));
    let applied = report.applied.expect("a pressure load");
    for (side, upper, pressure) in [(0, true, PRESSURE), (1, false, 2.0 * PRESSURE)] {
        let expected = pressure * pad_area(&mesh, upper);
        assert!(
            (applied.force[side] - expected).abs() <= 1e-9 * expected,
            "side {side}"
        );
        let carried = side_force(&mesh, &uneven.r_n, upper);
        assert!(
            (carried - expected).abs() <= 1e-8 * expected,
            "side {side}: {carried}"
        );
    }
}

#[test]
fn a_pressure_set_written_wrong_is_an_error_naming_it() {
    let params = Params::defaults(
        &SlidingEquilibrium,
        &[
            ("load", Value::Str("pressure".into())),
            ("pressure_sets", Value::Str("pad_backs=high".into())),
        ],
    );
    let mesh = coarse_brake();
    let model = model(&mesh, "hub, pad_backs:xy", &[]);
    let inputs = Inputs(BTreeMap::from([(
        "model".to_string(),
        crate::stage::Input::One(std::sync::Arc::new(Artifact::Model(Box::new(model)))),
    )]));
    let err = SlidingEquilibrium.run(&params, &inputs).unwrap_err();
    assert!(
        err.message
            .contains("pressure_sets: `pad_backs=high`: `high` is not a pressure in Pa"),
        "{err}"
    );
}

/// A disc block under a pad of two parts meshed apart, one metre off the axis: a lining
/// (2 × 2 across, its bottom paired node to node with the disc's top) under a backplate
/// (3 × 3 across), tied by `ties` with `tie_method`; the disc held at its base, the
/// backplate's back (`pad_backs`) guided in-plane.
fn tied_pad(ties: &str, tie_method: &str) -> Model {
    use crate::artifact::mesh::ContactPair;
    use crate::mesh::structured::block;
    use squeal_model::assemble::{Assemble, assemble_model};
    let (width, offset) = (0.02, 1.0);
    let mut mesh = Mesh::default();
    let mut add = |name: &str, counts: [usize; 3], z0: f64, height: f64, part: u32| {
        let piece = block([width, width, height], counts, "disc");
        let first = mesh.nodes.len() as u32;
        mesh.nodes
            .extend(piece.nodes.iter().map(|x| [x[0] + offset, x[1], x[2] + z0]));
        mesh.elements.extend_shifted(&piece.elements, first, part);
        for (set, nodes) in &piece.node_sets {
            let nodes = nodes.iter().map(|node| node + first).collect();
            mesh.node_sets.insert(format!("{name}_{set}"), nodes);
        }
    };
    add("disc", [2, 2, 2], 0.0, 0.03, 0);
    add("lining", [2, 2, 1], 0.03, 0.004, 1);
    add("plate", [3, 3, 1], 0.034, 0.006, 1);
    mesh.parts = vec!["disc".into(), "pad".into()];
    let cell = width / 2.0;
    let share = |c: f64| {
        let edge = (c - offset).abs() < 1e-12 || (c - offset - width).abs() < 1e-12;
        let side = c.abs() < 1e-12 || (c - width).abs() < 1e-12;
        if edge || side { 0.5 } else { 1.0 }
    };
    let pairs: Vec<ContactPair> = mesh.node_sets["disc_z1"]
        .iter()
        .zip(&mesh.node_sets["lining_z0"])
        .map(|(&disc, &pad)| {
            let x = mesh.nodes[disc as usize];
            assert!((0..2).all(|axis| (x[axis] - mesh.nodes[pad as usize][axis]).abs() < 1e-15));
            ContactPair::node_to_node(
                disc,
                pad,
                [0.0, 0.0, 1.0],
                cell * cell * share(x[0]) * share(x[1]),
            )
        })
        .collect();
    mesh.contact_pairs = pairs;
    mesh.node_sets
        .insert("base".into(), mesh.node_sets["disc_z0"].clone());
    mesh.node_sets
        .insert("pad_backs".into(), mesh.node_sets["plate_z1"].clone());
    let params = Params::defaults(
        &Assemble,
        &[
            ("clamped", Value::Str("base, pad_backs:xy".into())),
            ("ties", Value::Str(ties.into())),
            ("tie_method", Value::Str(tie_method.into())),
        ],
    )
    .read::<Assemble>()
    .unwrap();
    assemble_model(&mesh, &params).unwrap().0
}

/// The lining and its backplate, tied, float as one body: the pressure on the backplate's back
/// passes the tie and the contact carries it whole, whichever side the slave and either
/// method.
#[test]
fn a_pad_of_a_lining_tied_to_its_backplate_carries_the_pressure() {
    for method in ["collocation", "mortar"] {
        for ties in ["lining_z1 -> plate_z0", "plate_z0 -> lining_z1"] {
            let model = tied_pad(ties, method);
            assert!(!model.tied.is_empty());
            let (equilibrium, report) =
                pressed(&model, 0.38, Solver::SemismoothNewton, &settings());
            let applied = report.applied.unwrap();
            assert_eq!(applied.floating_bodies, 1, "{method} {ties}");
            let expected = PRESSURE * 0.02 * 0.02;
            let contact = side_force(&model.mesh, &equilibrium.r_n, true);
            assert!(
                (contact - expected).abs() <= 1e-10 * expected,
                "{method} {ties}: {contact} N against {expected} N"
            );
        }
    }
}

//! Verification of the stability stage (`docs/science.md` §8): Hoffmann's two-DOF model, the
//! friction-direction damping of one sliding point, Krylov against the dense solve on a coarse brake,
//! μ = 0 against the real modes, and the real-mode projection's error.

use std::collections::BTreeMap;
use std::sync::Arc;

use faer::c64;

use super::*;
use crate::artifact::CscMatrix;
use crate::artifact::mesh::{ContactPair, Mesh};
use crate::fixtures::{coarse_brake, sliding_equilibrium, small_brake, test_model};
use crate::stability::sliding::Part;
use crate::stage::{Input, Value};

/// The stage reads the Hoffmann model's Matrix Market files of `pipelines/hoffmann`
/// (its eigenvalues are verified in the verification suite), whole at μ = 0.38 or as
/// `K0 + μ Kf`.
#[test]
fn the_matrices_stage_reads_matrix_market_files() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../pipelines/hoffmann");
    for (k_file, kf_file) in [("K.mtx", ""), ("K0.mtx", "Kf.mtx")] {
        let mut params = BTreeMap::new();
        for (name, file) in [
            ("m_path", "M.mtx"),
            ("c_path", "C.mtx"),
            ("k_path", k_file),
            ("kf_path", kf_file),
        ] {
            let path = if file.is_empty() {
                String::new()
            } else {
                dir.join(file).display().to_string()
            };
            params.insert(name.to_string(), Value::Str(path));
        }
        params.insert("f_max_hz".into(), Value::Float(0.0));
        params.insert("mu".into(), Value::Float(0.38));
        let outputs = matrices::StabilityMatrices
            .run(&Params(params), &Inputs::default())
            .unwrap();
        let table = outputs["eigenvalues"].as_table().unwrap();
        let Some(crate::table::ColumnData::Bool(unstable)) = table.column("unstable") else {
            panic!("no unstable column")
        };
        // The flutter pair: equal frequencies, one growing, one decaying.
        let Some(crate::table::ColumnData::F64(re)) = table.column("re") else {
            panic!()
        };
        assert_eq!(unstable.iter().filter(|u| **u).count(), 1);
        let growing = re[unstable.iter().position(|u| *u).unwrap()];
        assert!((growing - 0.045175).abs() < 1e-6, "{k_file}: {growing}");
    }
}

#[test]
fn friction_direction_damping_of_one_sliding_point() {
    // A pad node of mass m on springs k, pressed with N on a clamped disc node at radius R.
    let (m, k, normal_force, radius, omega, mu) = (2.0, 3e6, 150.0, 0.3, 4.0, 0.38);
    let mesh = Mesh {
        nodes: vec![[radius, 0.0, 0.0], [radius, 0.0, 0.0]],
        contact_pairs: vec![ContactPair::node_to_node(1, 0, [0.0, 0.0, 1.0], 1e-4)],
        ..Mesh::default()
    };
    let diagonal =
        |value: f64| CscMatrix::from_triplets(3, 3, (0..3).map(|i| (i, i, value)).collect());
    let model = Model {
        mesh: mesh.clone(),
        dof_of_node: vec![[Some(0), Some(1), Some(2)], [None, None, None]],
        M: diagonal(m),
        K: diagonal(k),
        C: diagonal(0.0),
        tied: Vec::new(),
    };
    let frames = crate::contact::frames(&mesh, omega).unwrap();
    let equilibrium = Equilibrium {
        u: vec![0.0; 3],
        r_n: vec![normal_force],
        gap: vec![0.0],
        closed: vec![true],
        frames,
        mu,
        omega,
    };
    let solution = solve(&model, &equilibrium, &Settings::default()).unwrap();
    // Cross-slip (b = ∓x here): m ÿ + (μN/V) ẏ + k y = 0; along t: undamped.
    let c = mu * normal_force / (omega * radius);
    let damped = c64::new(-c / (2.0 * m), (k / m - (c / (2.0 * m)).powi(2)).sqrt());
    let undamped = c64::new(0.0, (k / m).sqrt());
    let mut expected = [damped, undamped];
    expected.sort_by(|a, b| a.im.total_cmp(&b.im));
    assert_eq!(solution.pairs.len(), 2);
    for (pair, expected) in solution.pairs.iter().zip(expected) {
        assert!(
            (pair.lambda - expected).norm() <= 1e-10 * expected.norm(),
            "{} vs {expected}",
            pair.lambda
        );
        assert!(pair.residual < 1e-12);
    }
    // Without the term, both are undamped.
    let settings = Settings {
        friction_damping: false,
        ..Settings::default()
    };
    for pair in solve(&model, &equilibrium, &settings).unwrap().pairs {
        assert!(pair.lambda.re.abs() <= 1e-10 * pair.lambda.norm());
    }
}

/// Matches `found` to `reference` one to one (both sorted by frequency): the largest relative
/// distance, or a panic naming what is missing or extra.
#[test]
fn the_operators_paired_product_equals_the_two_products_of_m_and_c() {
    // With friction damping, Ĉ has entries (pad–disc couplings) outside M's pattern.
    let (model, _) = test_model(&small_brake(), "hub, pad_backs", &[]);
    let equilibrium = sliding_equilibrium(&model, 0.6, 4.0);
    let system = SlidingSystem::new(&model, &equilibrium, true).unwrap();
    let m = system.dim();
    for width in [1, 3, 8] {
        let block = |seed: usize| {
            faer::Mat::<c64>::from_fn(m, width, |i, j| {
                let t = (i * 7 + j * 13 + seed) as f64;
                c64::new(t.sin(), (0.3 * t).cos())
            })
        };
        let (X, Y) = (block(1), block(2));
        let paired = system.apply_mass_damping(X.as_ref(), Y.as_ref());
        let separate =
            system.apply_block(Part::M, X.as_ref()) + system.apply_block(Part::C, Y.as_ref());
        let error = (&paired - &separate).norm_max() / separate.norm_max();
        assert!(
            error < 1e-14,
            "width {width}: relative difference {error:.1e}"
        );
    }
}

#[test]
fn a_band_wider_than_the_disks_of_the_basis_is_refused_with_what_to_change() {
    // Divergence rates up to ±100 %: the band's wedge |Re λ| ≤ Im λ / 2 outgrows the disks
    // of 160 vectors within a few shifts. The search must stop there and say what to change,
    // not retry ever closer shifts.
    let mesh = small_brake();
    let (model, _) = test_model(&mesh, "hub, pad_backs", &[]);
    let equilibrium = sliding_equilibrium(&model, 0.6, 4.0);
    let settings = Settings {
        f_max_hz: 12_000.0,
        max_divergence_rate: 1.0,
        dense_limit: 0,
        krylov: KrylovOptions {
            per_shift: 24,
            max_basis: 160,
            ..KrylovOptions::default()
        },
        ..Settings::default()
    };
    let error = match solve(&model, &equilibrium, &settings) {
        Ok(solution) => panic!(
            "solved a band wider than its disks: {:?}",
            solution.report.band.shifts
        ),
        Err(error) => error.to_string(),
    };
    eprintln!("{error}");
    assert!(
        error.contains("off the frequency axis")
            && error.contains("lower max_divergence_rate or raise max_basis"),
        "{error}"
    );
}

/// As the sliding speed V = ω r vanishes, the friction-direction damping μN/V grows without
/// bound and locks the contact nodes' motion across the sliding direction: the eigenvalues
/// converge to those of that constrained limit instead of the solve failing.
#[test]
fn a_vanishing_sliding_speed_reaches_its_limit_instead_of_failing() {
    let mesh = small_brake();
    let (model, _) = test_model(&mesh, "hub, pad_backs", &[]);
    let settings = Settings {
        f_max_hz: 6_000.0,
        dense_limit: 0,
        ..Settings::default()
    };
    let solve_at = |omega: f64| {
        solve(&model, &sliding_equilibrium(&model, 0.6, omega), &settings)
            .unwrap_or_else(|err| panic!("ω = {omega:e} rad/s: {err}"))
            .pairs
    };
    let limit = solve_at(1e-9);
    assert!(!limit.is_empty());
    assert!(limit.iter().all(|pair| pair.residual < 1e-10));
    for (omega, tolerance) in [(1e-3, 1e-4), (1e-6, 1e-6)] {
        let pairs = solve_at(omega);
        assert_eq!(pairs.len(), limit.len(), "ω = {omega:e} rad/s");
        let worst = nearest_relative_errors(&limit, &pairs)
            .into_iter()
            .fold(0.0, f64::max);
        eprintln!("ω = {omega:e} rad/s: eigenvalues within {worst:.1e} of the limit");
        assert!(worst < tolerance, "ω = {omega:e} rad/s: {worst:e}");
    }
}

#[test]
fn real_mode_projection_approaches_krylov() {
    let mesh = small_brake();
    let (model, _) = test_model(&mesh, "hub, pad_backs", &[]);
    let equilibrium = sliding_equilibrium(&model, 0.6, 4.0);
    let f_max_hz = 6_000.0;
    let reference = solve(
        &model,
        &equilibrium,
        &Settings {
            f_max_hz,
            dense_limit: 0,
            ..Settings::default()
        },
    )
    .unwrap();
    let error_with = |n_real_modes: usize| {
        let projected = solve(
            &model,
            &equilibrium,
            &Settings {
                f_max_hz,
                method: Method::RealModeProjection { n_real_modes },
                ..Settings::default()
            },
        )
        .unwrap();
        // Error of each reference eigenvalue against the nearest projected one.
        nearest_relative_errors(&reference.pairs, &projected.pairs)
            .into_iter()
            .fold(0.0, f64::max)
    };
    let n = reference.pairs.len();
    let coarse = error_with(n + n / 2);
    let fine = error_with(4 * n);
    eprintln!(
        "projection error: {coarse:.2e} with {} modes, {fine:.2e} with {}",
        n + n / 2,
        4 * n
    );
    assert!(fine < coarse, "{fine:e} vs {coarse:e}");
    assert!(fine < 1e-2, "{fine:e}");
}

#[test]
fn the_stage_writes_its_tables_figure_and_vtu_and_tracks_a_sweep() {
    let mesh = small_brake();
    let (model, _) = test_model(&mesh, "hub, pad_backs", &[]);
    let model = Arc::new(Artifact::Model(Box::new(model)));
    let params = Params::defaults;
    let mut points = Vec::new();
    for mu in [0.3, 0.45, 0.6] {
        let Artifact::Model(inner) = model.as_ref() else {
            unreachable!()
        };
        let equilibrium = Arc::new(Artifact::Equilibrium(Box::new(sliding_equilibrium(
            inner, mu, 4.0,
        ))));
        let inputs = Inputs(BTreeMap::from([
            ("model".to_string(), Input::One(model.clone())),
            ("equilibrium".to_string(), Input::One(equilibrium)),
        ]));
        let outputs = Stability
            .run(
                &params(&Stability, &[("f_max_hz", Value::Float(6000.0))]),
                &inputs,
            )
            .unwrap();
        let eigenvalues = outputs["eigenvalues"].as_table().unwrap();
        for column in [
            "mode",
            "freq_hz",
            "re",
            "im",
            "divergence_rate",
            "unstable",
            "residual",
        ] {
            assert!(eigenvalues.column(column).is_some(), "{column}");
        }
        let shapes = outputs["shapes"].as_table().unwrap();
        assert!(shapes.column("mode_0001_re").is_some() && shapes.column("mode_0001_im").is_some());
        // The complex modes hold what the tables hold, the shapes over the model's DOFs.
        let Artifact::ComplexModes(modes) = &outputs["modes"] else {
            panic!("no complex modes")
        };
        assert_eq!(
            modes
                .modes
                .iter()
                .map(|mode| mode.number)
                .collect::<Vec<_>>(),
            eigenvalues.i64("mode").unwrap()
        );
        for (column, value) in [
            (
                "re",
                &(|mode: &ComplexMode| mode.re) as &dyn Fn(&ComplexMode) -> f64,
            ),
            ("im", &|mode| mode.im),
            ("freq_hz", &|mode| mode.freq_hz()),
            ("residual", &|mode| mode.residual),
        ] {
            let values: Vec<f64> = modes.modes.iter().map(value).collect();
            assert_eq!(values, eigenvalues.f64(column).unwrap(), "{column}");
        }
        let dofs = shapes.i64("dof").unwrap();
        for (mode, shape) in modes.with_shapes() {
            for (part, values) in [("re", &shape.re), ("im", &shape.im)] {
                let column = shapes
                    .f64(&format!("mode_{:04}_{part}", mode.number))
                    .unwrap();
                for (row, &dof) in dofs.iter().enumerate() {
                    let expected = if dof < 0 { 0.0 } else { values[dof as usize] };
                    assert_eq!(column[row], expected);
                }
            }
        }
        let Artifact::Figure(diagram) = &outputs["diagram"] else {
            panic!()
        };
        assert!(diagram.svg.contains("Stability diagram"));
        let Artifact::Document(vtu) = &outputs["unstable_modes"] else {
            panic!()
        };
        let vtu = String::from_utf8(vtu.bytes.clone()).unwrap();
        let Some(crate::table::ColumnData::Bool(unstable)) = eigenvalues.column("unstable") else {
            panic!()
        };
        assert_eq!(
            vtu.matches("_re\"").count(),
            unstable.iter().filter(|u| **u).count()
        );
        let coords = vec![("mu".to_string(), Value::Float(mu))];
        points.push((coords, Arc::new(outputs["modes"].clone())));
    }
    let inputs = Inputs(BTreeMap::from([(
        "complex_modes".to_string(),
        Input::Many(points),
    )]));
    let outputs = track::Track
        .run(&params(&track::Track, &[]), &inputs)
        .unwrap();
    let tracked = outputs["tracked"].as_table().unwrap();
    let (Some(crate::table::ColumnData::I64(branch)), Some(crate::table::ColumnData::F64(mu))) =
        (tracked.column("branch"), tracked.column("mu"))
    else {
        panic!()
    };
    // A branch holds at most one mode per μ, and most modes continue through the sweep.
    let mut seen = std::collections::BTreeSet::new();
    for (branch, mu) in branch.iter().zip(mu) {
        assert!(
            seen.insert((*branch, mu.to_bits())),
            "branch {branch} twice at mu {mu}"
        );
    }
    let n_branches = branch.iter().max().copied().unwrap() as usize;
    let rows_per_point = tracked.n_rows() / 3;
    assert!(
        n_branches < 2 * rows_per_point,
        "{n_branches} branches for {rows_per_point} modes"
    );
}

#[test]
fn an_equilibrium_of_another_model_is_refused() {
    let mesh = small_brake();
    let (clamped, _) = test_model(&mesh, "hub, pad_backs", &[]);
    let (free_pads, _) = test_model(&mesh, "hub", &[]);
    let equilibrium = sliding_equilibrium(&clamped, 0.38, 4.0);
    let err = solve(&free_pads, &equilibrium, &Settings::default())
        .err()
        .unwrap();
    let expected = format!(
        "the equilibrium does not belong to this model: it has {} DOFs and {} contact pairs, the model {} and",
        clamped.n_dofs(),
        mesh.contact_pairs.len(),
        free_pads.n_dofs()
    );
    assert!(err.message.contains(&expected), "{err}");
}

#[test]
fn an_equilibrium_without_contact_is_an_error() {
    let mesh = small_brake();
    let (model, _) = test_model(&mesh, "hub, pad_backs", &[]);
    let mut equilibrium = sliding_equilibrium(&model, 0.38, 4.0);
    equilibrium
        .closed
        .iter_mut()
        .for_each(|closed| *closed = false);
    let err = solve(&model, &equilibrium, &Settings::default())
        .err()
        .unwrap();
    assert!(err.message.contains("no contact pair is closed"), "{err}");
}

#[test]
fn mac_pairs_modes_one_to_one() {
    let A = faer::Mat::<c64>::from_fn(4, 2, |i, j| c64::new(f64::from(u8::from(i == j)), 0.0));
    let B = faer::Mat::<c64>::from_fn(4, 2, |i, j| {
        c64::new(
            f64::from(u8::from(i == 1 - j)),
            0.1 * f64::from(u8::from(i == 3)),
        )
    });
    let mac = track::mac_matrix(&A, &B);
    assert!((mac[(0, 1)] - 1.0 / 1.01).abs() < 1e-12);
    let pairing = track::pair_modes(&mac, 0.5);
    assert_eq!(pairing[0].map(|p| p.0), Some(1));
    assert_eq!(pairing[1].map(|p| p.0), Some(0));
}

/// The engine keys downstream stages by output bytes: the eigenvalues and shapes must not
/// depend on how many threads computed them.
#[test]
fn stability_results_do_not_depend_on_the_thread_count() {
    squeal_linalg::fix_global_parallelism();
    // Large enough for the Krylov solver (beyond the dense limit) and for several row chunks
    // of its tall products.
    let mesh = coarse_brake();
    let (model, _) = test_model(&mesh, "hub, pad_backs", &[]);
    let equilibrium = sliding_equilibrium(&model, 0.6, 4.0);
    let inputs = Inputs(BTreeMap::from([
        (
            "model".to_string(),
            Input::One(Arc::new(Artifact::Model(Box::new(model)))),
        ),
        (
            "equilibrium".to_string(),
            Input::One(Arc::new(Artifact::Equilibrium(Box::new(equilibrium)))),
        ),
    ]));
    let params = Params::defaults(&Stability, &[("f_max_hz", Value::Float(8000.0))]);
    crate::stage::assert_outputs_independent_of_threads(&Stability, &params, &inputs, "stability");
}

/// The condition numbers of the Krylov band (left vectors from a second band solve of the
/// transposed problem) against those of the dense solve, on the small brake with friction
/// coupling; the error bound holds the Krylov eigenvalue's distance to the dense one.
#[test]
fn krylov_condition_numbers_match_the_dense_solve() {
    let mesh = small_brake();
    let (model, _) = test_model(&mesh, "hub, pad_backs", &[]);
    let equilibrium = sliding_equilibrium(&model, 0.6, 4.0);
    let f_max_hz = 6_000.0;
    let dense = solve(
        &model,
        &equilibrium,
        &Settings {
            f_max_hz,
            dense_limit: usize::MAX,
            ..Settings::default()
        },
    )
    .unwrap();
    assert!(dense.report.dense);
    let krylov = solve(
        &model,
        &equilibrium,
        &Settings {
            f_max_hz,
            dense_limit: 0,
            condition_numbers: true,
            ..Settings::default()
        },
    )
    .unwrap();
    assert_eq!(krylov.pairs.len(), dense.pairs.len());
    let mut worst: f64 = 0.0;
    for pair in &krylov.pairs {
        let reference = dense
            .pairs
            .iter()
            .min_by(|a, b| {
                (a.lambda - pair.lambda)
                    .norm()
                    .total_cmp(&(b.lambda - pair.lambda).norm())
            })
            .unwrap();
        assert!(pair.condition.is_finite() && pair.condition >= 1.0);
        worst = worst.max((pair.condition - reference.condition).abs() / reference.condition);
        let distance = (pair.lambda - reference.lambda).norm() / reference.lambda.norm();
        let bounds = pair.condition * pair.residual + reference.condition * reference.residual;
        assert!(
            distance <= 10.0 * bounds.max(1e-15),
            "{distance:e} > {bounds:e}"
        );
    }
    let largest = krylov
        .pairs
        .iter()
        .map(|pair| pair.condition)
        .fold(0.0, f64::max);
    eprintln!(
        "{} eigenvalues: κ from 1 to {largest:.1}, Krylov within {worst:.1e} of dense",
        krylov.pairs.len()
    );
    assert!(worst < 1e-6, "{worst:e}");
}

/// The sliding system of the stacked blocks, every pair closed, with weighted rows: the disc
/// side of five pairs over three disc nodes, the pad side of the face's middle column as a
/// quadratic face's mid-edge rows (5/3 on the anchor, −1/3 on each neighbour, anchors of
/// node-to-node rows whose slaves are substituted).
fn weighted_sliding_problem(mesh: &Mesh, mu: f64) -> (Model, Equilibrium) {
    let (model, _) = test_model(mesh, "base, pad_backs:xy", &[]);
    let omega = 4.0;
    let frames = crate::contact::frames(&model.mesh, omega).unwrap();
    let n_pairs = model.mesh.contact_pairs.len();
    let equilibrium = Equilibrium {
        u: vec![0.0; model.n_dofs()],
        r_n: vec![100.0; n_pairs],
        gap: vec![0.0; n_pairs],
        closed: vec![true; n_pairs],
        frames,
        mu,
        omega,
    };
    (model, equilibrium)
}

#[test]
fn the_elimination_of_weighted_rows_keeps_every_closed_pair_closed() {
    let (mesh, discs, pads) = crate::fixtures::spread_pairs(
        &crate::mesh::structured::stacked_blocks(0.02, 0.03, 0.01),
        true,
    );
    assert_eq!((discs, pads), (5, 3));
    let mu = 0.38;
    let (model, equilibrium) = weighted_sliding_problem(&mesh, mu);
    let system = SlidingSystem::new(&model, &equilibrium, true).unwrap();
    let transposed = system.transposed();
    let columns = crate::contact::h_columns(&model, &equilibrium.frames);
    let row = |column: &[(usize, f64)], u: &[c64]| {
        column
            .iter()
            .map(|&(dof, value)| u[dof] * value)
            .sum::<c64>()
    };
    let mut worst = [0.0f64; 2];
    for seed in 0..4 {
        let q: Vec<c64> = (0..system.dim())
            .map(|i| {
                let t = (7 * i + 13 * seed) as f64;
                c64::new(t.sin(), (0.3 * t).cos())
            })
            .collect();
        let scale = q.iter().fold(0.0f64, |max, q| max.max(q.norm()));
        // u = Tᴺ q: H_n u = 0; w = Tᵘ q: (H_n + μ H_t) w = 0, on every pair.
        let (u, w) = (system.expand(&q), transposed.expand(&q));
        for pair in 0..model.mesh.contact_pairs.len() {
            let (normal, tangent) = (&columns[3 * pair], &columns[3 * pair + 1]);
            worst[0] = worst[0].max(row(normal, &u).norm() / scale);
            worst[1] = worst[1].max((row(normal, &w) + row(tangent, &w) * mu).norm() / scale);
        }
    }
    eprintln!(
        "largest |H_n Tᴺ q| {:.1e}, |G Tᵘ q| {:.1e} (of max |q|)",
        worst[0], worst[1]
    );
    assert!(worst[0] <= 1e-14 && worst[1] <= 1e-14, "{worst:?}");
    // One slave per closed pair.
    assert_eq!(
        system.dim(),
        model.n_dofs() - model.mesh.contact_pairs.len()
    );
}

#[test]
fn weighted_rows_that_reach_each_others_slaves_are_refused_naming_a_pair() {
    let mut mesh = crate::mesh::structured::stacked_blocks(0.02, 0.03, 0.01);
    // Pairs 0 and 1 each read the other's anchor.
    let (a, b) = (
        mesh.contact_pairs[0].pad_node(),
        mesh.contact_pairs[1].pad_node(),
    );
    mesh.contact_pairs[0].pad = vec![(a, 1.5), (b, -0.5)];
    mesh.contact_pairs[1].pad = vec![(b, 1.5), (a, -0.5)];
    let (model, equilibrium) = weighted_sliding_problem(&mesh, 0.38);
    let error = SlidingSystem::new(&model, &equilibrium, true)
        .err()
        .expect("a cycle is refused")
        .to_string();
    assert!(
        error.contains("closed pair 0") && error.contains("cycle"),
        "{error}"
    );
}

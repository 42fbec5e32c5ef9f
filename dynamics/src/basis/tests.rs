//! Verification of the bases: a basis spanning every DOF reproduces the full transient; the
//! reduced matrices are the dense projection `Tᵀ A T`, symmetric, and the vectors
//! `M`-orthonormal, with the rank reported; a
//! reduced run grows at the rate of the unstable mode it starts from; the completion by real
//! modes restores complex modes the stability stage did not seek; the residual indicator
//! vanishes on a full basis and tracks the true error of the others, and the adaptive basis
//! meets its target; bodies kept whole stay physical; clear errors; outputs independent of the
//! thread count.

use std::f64::consts::PI;
use std::sync::Arc;

use faer::Mat;
use faer::linalg::solvers::Solve;
use squeal_linalg::csc::symmetric_mul;
use squeal_linalg::tall::transpose_times;

use super::reduction::STIFFNESS;
use super::*;
use crate::artifact::Basis;
use crate::artifact::{ComplexMode, ComplexShape};
use crate::fixtures::{
    brake_inputs, brake_inputs_of, f64_column, growth_rate, most_unstable, transient_params,
};
use crate::mesh::brake::BrakeGeometry;
use crate::modes::Modes;
use crate::params::DeclaredParams;
use crate::stability::Stability;
use crate::stage::{Input, Value};
use crate::table::ColumnData;
use crate::transient::Transient;
use crate::transient::products::Products;

fn insert(inputs: &mut Inputs, port: &str, artifact: Artifact) {
    inputs
        .0
        .insert(port.to_string(), Input::One(Arc::new(artifact)));
}

/// The real modes of the fixture: the lowest `n_modes` (0: below `f_max_hz`).
fn real_modes(inputs: &Inputs, n_modes: usize, f_max_hz: f64) -> Artifact {
    let params = Params::defaults(
        &Modes,
        &[
            ("n_modes", Value::Int(n_modes as i64)),
            ("f_max_hz", Value::Float(f_max_hz)),
        ],
    );
    Modes.run(&params, inputs).unwrap()["modes"].clone()
}

fn quantity(table: &Table, name: &str) -> f64 {
    table.quantity(name).unwrap()
}

/// `max |a − b| / max |b|` over the f64 columns `names` of two tables.
fn relative_difference(a: &Table, b: &Table, names: &[&str]) -> f64 {
    names
        .iter()
        .map(|name| {
            let (x, y) = (f64_column(a, name), f64_column(b, name));
            assert_eq!(x.len(), y.len());
            let scale = y.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            let worst = x
                .iter()
                .zip(y)
                .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()));
            if scale > 0.0 { worst / scale } else { worst }
        })
        .fold(0.0, f64::max)
}

#[test]
fn a_basis_spanning_every_dof_reproduces_the_full_transient() {
    let mut inputs = brake_inputs();
    let n = inputs.get::<Model>("model").unwrap().n_dofs();
    let modes = real_modes(&inputs, n, 0.0);
    insert(&mut inputs, "modes", modes);
    // Every real mode, and every body kept whole (no vector at all: no fixed-interface mode
    // is left to compute, and an FC basis's modes vanish less their static parts).
    let every_mode = [
        ("kind", Value::Str("real".into())),
        ("n_modes", Value::Int(n as i64)),
        ("rank_tolerance", Value::Float(1e-8)),
    ];
    let every_body = [
        ("kind", Value::Str("craig_bampton".into())),
        ("n_modes", Value::Int(10)),
        ("keep_whole_up_to", Value::Int(n as i64)),
    ];
    let fc_every_body = fc_basis(&inputs, &[("keep_whole_up_to", Value::Int(n as i64))]);
    let summary = fc_every_body["summary"].as_table().unwrap();
    assert_eq!(quantity(summary, "n_vectors"), 0.0);
    assert_eq!(quantity(summary, "n_reduced"), n as f64);
    // A kick that opens and closes pairs: the contact laws are exercised, not only the
    // linear dynamics.
    let params = transient_params(&[
        ("initial", Value::Str("kick".into())),
        ("kick_velocity", Value::Float(1.0)),
        ("tau", Value::Float(2e-6)),
        ("duration", Value::Float(6e-4)),
        ("tolerance", Value::Float(1e-13)),
        ("n_snapshots", Value::Int(10)),
    ]);
    let full = Transient.run(&params, &inputs).unwrap();
    let table = |outputs: &Outputs, name: &str| outputs[name].as_table().unwrap().clone();
    let open = f64_column(&table(&full, "history"), "open")
        .iter()
        .fold(0.0_f64, |m, v| m.max(*v));
    assert!(open > 0.0, "the kick opens pairs");
    for overrides in [&every_mode[..], &every_body[..]] {
        let basis = ReductionBasis
            .run(&Params::defaults(&ReductionBasis, overrides), &inputs)
            .unwrap();
        let summary = basis["summary"].as_table().unwrap();
        assert_eq!(
            quantity(summary, "n_reduced"),
            n as f64,
            "{overrides:?}: the basis spans every DOF"
        );
        let mut inputs = inputs.clone();
        insert(&mut inputs, "basis", basis["basis"].clone());
        let reduced = Transient.run(&params, &inputs).unwrap();
        let indicator = quantity(reduced["summary"].as_table().unwrap(), "residual_indicator");
        assert!(
            indicator < 1e-8,
            "{overrides:?}: residual indicator {indicator:.2e}"
        );
        let history = [
            "u_n", "u_t", "v_n", "v_t", "kinetic", "open", "stick", "slide",
        ];
        let error = relative_difference(
            &table(&reduced, "history"),
            &table(&full, "history"),
            &history,
        );
        assert!(
            error < 1e-8,
            "{overrides:?}: history, reduced against full {error:.2e}"
        );
        let snapshots = table(&full, "snapshots");
        let steps: Vec<&str> = snapshots
            .columns()
            .iter()
            .map(|column| column.name.as_str())
            .filter(|name| name.starts_with("step_"))
            .collect();
        for name in ["snapshots", "velocity_snapshots"] {
            let error = relative_difference(&table(&reduced, name), &table(&full, name), &steps);
            assert!(
                error < 1e-8,
                "{overrides:?}: {name}, reduced against full {error:.2e}"
            );
        }
    }
}

/// The pads kept whole: their DOFs are coordinates, the vectors vanish on them and reduce the
/// disc alone, the reduced matrices are `Tᵀ A T` with `C` Rayleigh's row by row, and a run on
/// the basis is closer to the full model than on the paper's basis of the same modes (a few:
/// on this small brake, the modes below the default cut-off already span the pads).
#[test]
fn bodies_kept_whole_stay_physical_and_the_vectors_reduce_the_others() {
    // Pucks of two layers: one layer would have every free DOF on the interface.
    let inputs = brake_inputs_of(&BrakeGeometry {
        puck_layers: 2,
        ..BrakeGeometry::small()
    });
    let model: &Model = inputs.get("model").unwrap();
    let bodies = components(&[&model.M, &model.C, &model.K]);
    let disc = bodies.iter().map(Vec::len).max().unwrap();
    let pads: Vec<usize> = bodies
        .iter()
        .filter(|body| body.len() < disc)
        .flatten()
        .copied()
        .collect();
    assert!(bodies.len() > 2 && !pads.is_empty());
    let whole = fc_basis(
        &inputs,
        &[("keep_whole_up_to", Value::Int(disc as i64 - 1))],
    );
    let summary = whole["summary"].as_table().unwrap();
    let Artifact::Basis(basis) = &whole["basis"] else {
        panic!("not a basis")
    };
    let contact = interface_dofs(model);
    let mut physical = [contact.clone(), pads.clone()].concat();
    physical.sort_unstable();
    physical.dedup();
    let interface: Vec<usize> = basis.interface.iter().map(|&dof| dof as usize).collect();
    assert_eq!(interface, physical);
    assert_eq!(quantity(summary, "n_interface"), contact.len() as f64);
    assert_eq!(
        quantity(summary, "n_whole"),
        (physical.len() - contact.len()) as f64
    );
    assert_eq!(
        basis.n_reduced() as f64,
        quantity(summary, "n_interface")
            + quantity(summary, "n_whole")
            + quantity(summary, "n_vectors")
    );
    assert!(quantity(summary, "n_vectors") > 0.0 && quantity(summary, "n_whole") > 0.0);
    for vector in &basis.vectors {
        assert!(pads.iter().all(|&dof| vector[dof] == 0.0));
    }
    assert_reduced_matrices_are_the_dense_projection(model, basis);
    let params = transient_params(&[
        ("tau", Value::Float(2e-6)),
        ("duration", Value::Float(4e-4)),
        ("amplitude", Value::Float(1e-6)),
    ]);
    let indicator = |basis: &Outputs| {
        let mut inputs = inputs.clone();
        insert(&mut inputs, "basis", basis["basis"].clone());
        let outputs = Transient.run(&params, &inputs).unwrap();
        quantity(outputs["summary"].as_table().unwrap(), "residual_indicator")
    };
    let paper = fc_basis(&inputs, &[("n_modes", Value::Int(4))]);
    let with_pads = fc_basis(
        &inputs,
        &[
            ("n_modes", Value::Int(4)),
            ("keep_whole_up_to", Value::Int(disc as i64 - 1)),
        ],
    );
    let (paper_indicator, with_pads_indicator) = (indicator(&paper), indicator(&with_pads));
    assert!(
        with_pads_indicator < 0.5 * paper_indicator,
        "residual indicator: pads whole {with_pads_indicator:.2e}, the paper's basis {paper_indicator:.2e}"
    );
    // Each vector lies on the disc alone, so the reduced `C` is Rayleigh's row by row and a
    // step streams `K` alone; the paper's vectors span the disc and the pads, whose Rayleigh
    // coefficients differ.
    let rayleigh = |outputs: &Outputs| {
        let Artifact::Basis(basis) = &outputs["basis"] else {
            panic!("not a basis")
        };
        Products::new(&basis.mass, &basis.damping, &basis.stiffness).is_rayleigh()
    };
    assert!(rayleigh(&with_pads) && !rayleigh(&paper));
}

/// The basis's reduced `M`, `C` and `K` against `Tᵀ A T` with the dense `T` (every body at
/// once, every block summed): the same to round-off, `K`'s static–modal blocks too (exact
/// zeros in the basis: `Φ` vanishes on the interface, `K S` off it).
fn assert_reduced_matrices_are_the_dense_projection(model: &Model, basis: &Basis) {
    let interface: Vec<usize> = basis.interface.iter().map(|&dof| dof as usize).collect();
    let T = StaticModes::new(model, &interface)
        .unwrap()
        .basis_matrix(basis);
    let n_r = basis.n_reduced();
    for (A, reduced, name) in [
        (&model.M, &basis.mass, "mass"),
        (&model.C, &basis.damping, "damping"),
        (&model.K, &basis.stiffness, "stiffness"),
    ] {
        let reference = transpose_times(T.as_ref(), symmetric_mul(A, T.as_ref()).as_ref());
        let reduced = reduced.to_dense();
        assert_eq!((reduced.nrows(), reduced.ncols()), (n_r, n_r));
        let error = (&reduced - &reference).norm_max() / reference.norm_max();
        assert!(error < 1e-12, "{name}: {error:.1e} from Tᵀ A T");
    }
}

/// The fixture's FC basis at the default cut-off, with its outputs.
fn fc_basis(inputs: &Inputs, overrides: &[(&str, Value)]) -> Outputs {
    ReductionBasis
        .run(&Params::defaults(&ReductionBasis, overrides), inputs)
        .unwrap()
}

#[test]
fn reduced_matrices_are_symmetric_and_the_vectors_M_orthonormal_with_the_rank_reported() {
    let inputs = brake_inputs();
    let outputs = fc_basis(&inputs, &[]);
    let summary = outputs["summary"].as_table().unwrap();
    let orthonormality = quantity(summary, "orthonormality_error");
    assert!(orthonormality < 1e-12, "ΦᵀMΦ − I: {orthonormality:.1e}");
    for matrix in ["mass", "damping", "stiffness"] {
        let asymmetry = quantity(summary, &format!("{matrix}_asymmetry"));
        assert!(
            asymmetry < 1e-12,
            "{matrix}: relative asymmetry {asymmetry:.1e}"
        );
    }
    let vectors = outputs["vectors"].as_table().unwrap();
    let kept = match vectors.column("kept") {
        Some(ColumnData::Bool(kept)) => kept.clone(),
        _ => panic!("no kept column"),
    };
    let remaining = f64_column(vectors, "remaining");
    let n_kept = kept.iter().filter(|&&k| k).count();
    assert_eq!(quantity(summary, "n_vectors"), n_kept as f64);
    for (k, &is_kept) in kept.iter().enumerate() {
        assert_eq!(is_kept, remaining[k] >= 1e-3, "candidate {k}");
    }
    let Artifact::Basis(basis) = &outputs["basis"] else {
        panic!("not a basis")
    };
    let model: &Model = inputs.get("model").unwrap();
    assert_eq!(basis.interface.len(), interface_dofs(model).len());
    assert_eq!(
        basis.n_reduced() as f64,
        quantity(summary, "n_interface") + quantity(summary, "n_vectors")
    );
    assert_reduced_matrices_are_the_dense_projection(model, basis);
    let n_r = basis.n_reduced();
    // The reduced stiffness of the static modes is the Schur complement of K_oo: positive
    // definite.
    let K_r = basis.stiffness.to_dense();
    assert!(K_r.as_ref().llt(faer::Side::Lower).is_ok());
    // A state in the span of T restricts to its own coordinates, `Φᵀ M S` read off the
    // reduced mass.
    let interface: Vec<usize> = basis.interface.iter().map(|&dof| dof as usize).collect();
    let x: Vec<f64> = (0..n_r)
        .map(|i| ((i * 7919) % 101) as f64 / 50.0 - 1.0)
        .collect();
    let X = faer::Mat::from_fn(n_r, 1, |i, _| x[i]);
    let u = basis.lift(X.as_ref());
    // The lift by the stored static modes is the one by solves with K_oo's factor.
    let T = StaticModes::new(model, &interface)
        .unwrap()
        .basis_matrix(basis);
    let by_solves = &T * &X;
    let scale = by_solves.col(0).iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let lift_gap =
        (0..model.n_dofs()).fold(0.0_f64, |m, i| m.max((u[(i, 0)] - by_solves[(i, 0)]).abs()));
    assert!(
        lift_gap < 1e-12 * scale,
        "T x by the stored static modes − by solves: {lift_gap:.2e} of {scale:.2e}"
    );
    let u: Vec<f64> = u.col(0).iter().copied().collect();
    let restricted = basis.restrict(&model.M, &u);
    let gap = restricted
        .iter()
        .zip(&x)
        .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(gap < 1e-12, "restrict(T x) − x: {gap:.2e}");
}

/// `Reduction` against the dense `Tᵀ A T`, `T = [S, V, W]`, for vectors `V` that vanish on the
/// interface (the stage's, whose `K` block against the static modes is set to zero) and `W`
/// that do not (whose block is summed).
#[test]
fn the_reduction_grown_by_blocks_is_the_dense_projection() {
    let inputs = brake_inputs();
    let model: &Model = inputs.get("model").unwrap();
    let static_modes = StaticModes::new(model, &interface_dofs(model)).unwrap();
    let n = model.n_dofs();
    let mut random = squeal_linalg::rng::SplitMix64::new(11);
    let W = Mat::from_fn(n, 3, |_, _| random.next_signed());
    let W_i = Mat::from_fn(static_modes.interface().len(), 3, |j, k| {
        W[(static_modes.interface()[j], k)]
    });
    let V = &W - static_modes.static_displacement(W_i.as_ref());
    let bodies = components(&[&model.M, &model.C, &model.K]);
    let mut reduction = Reduction::new(model, &static_modes, bodies);
    reduction.extend(model, V.as_ref());
    reduction.extend(model, W.as_ref());
    let n_i = static_modes.interface().len();
    let S = static_modes.static_displacement(Mat::<f64>::identity(n_i, n_i).as_ref());
    let mut T = Mat::<f64>::zeros(n, n_i + 6);
    T.as_mut().subcols_mut(0, n_i).copy_from(&S);
    T.as_mut().subcols_mut(n_i, 3).copy_from(&V);
    T.as_mut().subcols_mut(n_i + 3, 3).copy_from(&W);
    for (which, A) in [&model.M, &model.C, &model.K].into_iter().enumerate() {
        let reference = transpose_times(T.as_ref(), symmetric_mul(A, T.as_ref()).as_ref());
        let error = (&reduction.matrices[which] - &reference).norm_max() / reference.norm_max();
        assert!(error < 1e-12, "matrix {which}: {error:.1e} from Tᵀ A T");
    }
    // `K` between the static modes and `W` is not zero: it was summed, not dropped.
    let coupling = reduction.matrices[STIFFNESS]
        .as_ref()
        .submatrix(0, n_i + 3, n_i, 3)
        .norm_max();
    assert!(coupling > 1e-3 * reduction.matrices[STIFFNESS].norm_max());
}

#[test]
fn a_reduced_run_grows_at_the_rate_of_the_unstable_mode_it_starts_from() {
    let mut inputs = brake_inputs();
    let most = most_unstable(&inputs);
    let (expected, period) = (most.re, 2.0 * PI / most.im);
    let basis = fc_basis(&inputs, &[]);
    insert(&mut inputs, "basis", basis["basis"].clone());
    let tau = period / 60.0;
    let run = |indicator_samples: i64| {
        Transient
            .run(
                &transient_params(&[
                    ("tau", Value::Float(tau)),
                    ("duration", Value::Float((3.0 / expected).min(4000.0 * tau))),
                    ("amplitude", Value::Float(1e-9)),
                    ("indicator_samples", Value::Int(indicator_samples)),
                ]),
                &inputs,
            )
            .unwrap()
    };
    let outputs = run(20);
    let measured = growth_rate(outputs["history"].as_table().unwrap(), period, tau);
    assert!(
        (measured - expected).abs() < 0.02 * expected,
        "reduced growth rate {measured} /s against Re lambda = {expected} /s"
    );
    // Without the indicator: the same run, and a summary that says it was not computed.
    let without = run(0);
    assert!(quantity(outputs["summary"].as_table().unwrap(), "residual_indicator").is_finite());
    assert!(quantity(without["summary"].as_table().unwrap(), "residual_indicator").is_nan());
    for table in ["history", "snapshots"] {
        assert!(
            outputs[table].as_table().unwrap() == without[table].as_table().unwrap(),
            "{table}: the indicator changed the run"
        );
    }
    // The modal coordinates are eliminated last, so the bodies' interface blocks, which do not
    // couple, stay apart in J's factor: the dense factor would hold n² entries (supernodes are
    // stored whole).
    let summary = outputs["summary"].as_table().unwrap();
    let n = quantity(summary, "unknowns");
    let entries = quantity(summary, "factor_entries");
    assert!(
        entries < 0.7 * n * n,
        "J's factor holds {entries} entries for {n} reduced unknowns"
    );
}

#[test]
fn bad_requests_are_refused_with_what_is_missing() {
    let inputs = brake_inputs();
    let refuse = |overrides: &[(&str, Value)], inputs: &Inputs| {
        ReductionBasis
            .run(&Params::defaults(&ReductionBasis, overrides), inputs)
            .unwrap_err()
            .to_string()
    };
    let message = refuse(&[("kind", Value::Str("real".into()))], &inputs);
    assert!(message.contains("`modes` input"), "{message}");
    let message = refuse(
        &[
            ("kind", Value::Str("modes".into())),
            ("modes", Value::Str("1, 99999".into())),
        ],
        &inputs,
    );
    assert!(message.contains("mode 99999"), "{message}");
    let message = refuse(
        &[
            ("kind", Value::Str("craig_bampton".into())),
            ("f_cutoff_hz", Value::Float(1.0)),
        ],
        &inputs,
    );
    assert!(
        message.contains("no craig_bampton vector (below 1.0 Hz)"),
        "{message}"
    );
    let message = refuse(&[("n_modes", Value::Int(100_000))], &inputs);
    assert!(message.contains("n_modes = 100000"), "{message}");
    for tolerance in [0.0, 1.0] {
        let message = refuse(&[("rank_tolerance", Value::Float(tolerance))], &inputs);
        assert!(
            message.contains(&format!("rank_tolerance = {tolerance}: a fraction")),
            "{message}"
        );
    }
    let mut without_stability = inputs.clone();
    without_stability.0.remove("complex_modes");
    let message = refuse(&[], &without_stability);
    assert!(message.contains("complex_modes"), "{message}");
    let params = Params::defaults(&ReductionBasis, &[("modes", Value::Str("1, x".into()))]);
    let message = ReductionBasis.read_params(&params).unwrap_err().to_string();
    assert!(message.contains("`x`"), "{message}");
    // An adaptive basis names a probe without steps, and a target it cannot reach with the
    // indicator of every round.
    let adaptive = |overrides: &[(&str, Value)]| {
        let mut all = vec![
            ("kind", Value::Str("adaptive".into())),
            ("n_modes", Value::Int(2)),
            ("probe_duration", Value::Float(2e-5)),
        ];
        all.extend(overrides.iter().cloned());
        refuse(&all, &inputs)
    };
    for duration in [0.0, 1e3] {
        let message = adaptive(&[("probe_duration", Value::Float(duration))]);
        assert!(message.contains("between 1 and 10000000"), "{message}");
    }
    let message = adaptive(&[
        ("target", Value::Float(1e-12)),
        ("max_rounds", Value::Int(2)),
    ]);
    assert!(
        message.contains("after 2 rounds") && message.contains("per round: "),
        "{message}"
    );
}

#[test]
fn a_transient_refuses_a_basis_built_on_another_model() {
    let inputs = brake_inputs();
    let basis = fc_basis(&inputs, &[("n_modes", Value::Int(4))])["basis"].clone();
    let model = inputs.get::<Model>("model").unwrap();
    let params = transient_params(&[("duration", Value::Float(1e-5))]);
    let run_on = |model: Model| {
        let mut inputs = inputs.clone();
        insert(&mut inputs, "model", Artifact::Model(Box::new(model)));
        insert(&mut inputs, "basis", basis.clone());
        Transient.run(&params, &inputs).map(drop)
    };
    assert!(run_on(model.clone()).is_ok(), "the basis's own model");
    // The same mesh and DOFs, a stiffer material: the basis's reduced matrices are the old
    // model's, so the run is refused, not run on them.
    let mut stiffer = model.clone();
    stiffer.K.values.iter_mut().for_each(|value| *value *= 1.01);
    let message = run_on(stiffer).unwrap_err().to_string();
    assert!(
        message
            .contains("the basis was built on another model: its reduced matrices come from other"),
        "{message}"
    );
    // A basis whose stored parts do not fit its own model (a damaged artifact) is refused by
    // name, never indexed past an end.
    let Artifact::Basis(whole) = &basis else {
        panic!("not a basis")
    };
    let refused = |damage: fn(&mut Basis)| {
        let mut damaged = whole.as_ref().clone();
        damage(&mut damaged);
        let mut inputs = inputs.clone();
        insert(&mut inputs, "basis", Artifact::Basis(Box::new(damaged)));
        Transient.run(&params, &inputs).unwrap_err().to_string()
    };
    let message = refused(|basis| {
        basis.static_modes[0].values.pop();
    });
    assert!(
        message.contains("does not belong to this model: a block of its static modes"),
        "{message}"
    );
    let message = refused(|basis| basis.stiffness.row_idx[0] = basis.n_reduced());
    assert!(
        message.contains("does not belong to this model: a reduced matrix"),
        "{message}"
    );
}

#[test]
fn the_modes_the_stability_band_leaves_out_lie_in_the_span_of_the_basis() {
    let mut inputs = brake_inputs();
    // Every complex mode below 8 kHz, then only the lightly damped ones.
    let stability = |rate: f64, inputs: &Inputs| {
        let params = Params::defaults(
            &Stability,
            &[
                ("f_max_hz", Value::Float(8000.0)),
                ("max_divergence_rate", Value::Float(rate)),
            ],
        );
        Stability.run(&params, inputs).unwrap()
    };
    let all = stability(1.0, &inputs);
    let narrow = stability(0.005, &inputs);
    let count =
        |outputs: &Outputs| f64_column(outputs["eigenvalues"].as_table().unwrap(), "re").len();
    assert!(
        count(&narrow) < count(&all),
        "the narrow band leaves modes out"
    );
    insert(&mut inputs, "complex_modes", narrow["modes"].clone());
    let modes = real_modes(&inputs, 0, 12_000.0);
    insert(&mut inputs, "modes", modes);
    let cutoff = [("f_cutoff_hz", Value::Float(8000.0))];
    let completed = fc_basis(&inputs, &cutoff);
    let plain = fc_basis(
        &inputs,
        &[cutoff[0].clone(), ("complete", Value::Bool(false))],
    );
    // How much of each complex mode of the wide band lies outside a basis.
    let model: &Model = inputs.get("model").unwrap();
    let Artifact::ComplexModes(modes) = &all["modes"] else {
        panic!("no complex modes")
    };
    let modes: Vec<(&ComplexMode, &ComplexShape)> = modes.with_shapes().collect();
    let narrow_freqs = f64_column(narrow["eigenvalues"].as_table().unwrap(), "freq_hz").to_vec();
    let missing: Vec<usize> = (0..modes.len())
        .filter(|&k| {
            let freq_hz = modes[k].0.freq_hz();
            freq_hz <= 8000.0 && narrow_freqs.iter().all(|f| (f - freq_hz).abs() > 1e-6 * f)
        })
        .collect();
    assert!(!missing.is_empty());
    // The largest fraction of a left-out mode's M-norm outside the span of a basis.
    let worst_outside = |outputs: &Outputs| {
        let Artifact::Basis(basis) = &outputs["basis"] else {
            panic!("not a basis")
        };
        let static_modes = StaticModes::new(model, &interface_dofs(model)).unwrap();
        let T = static_modes.basis_matrix(basis);
        let MT = symmetric_mul(&model.M, T.as_ref());
        let gram = transpose_times(T.as_ref(), MT.as_ref());
        let gram = gram.as_ref().llt(faer::Side::Lower).unwrap();
        let mut worst = 0.0_f64;
        for &k in &missing {
            for part in [&modes[k].1.re, &modes[k].1.im] {
                let u = Mat::from_fn(model.n_dofs(), 1, |dof, _| part[dof]);
                let M_norm = |u: &Mat<f64>| {
                    (u.transpose() * symmetric_mul(&model.M, u.as_ref()))[(0, 0)]
                        .max(0.0)
                        .sqrt()
                };
                let norm = M_norm(&u);
                if norm < 1e-3 {
                    continue;
                }
                // The M-orthogonal projection on span T, through its Gram matrix.
                let coefficients = gram.solve(MT.transpose() * &u);
                let outside = M_norm(&(&u - &T * &coefficients)) / norm;
                worst = worst.max(outside);
            }
        }
        worst
    };
    // Measured: 20 of the 38 modes below 8 kHz left out, held to 0.4 % with or without the
    // completion.
    let (with, without) = (worst_outside(&completed), worst_outside(&plain));
    assert!(
        without < 0.01,
        "a left-out mode is {without:.3} outside the basis"
    );
    assert!(with <= without + 1e-9, "{with} against {without}");
    // The completion adds only real modes mostly outside the span.
    let vectors = completed["vectors"].as_table().unwrap();
    let source = match vectors.column("source") {
        Some(ColumnData::Str(source)) => source.clone(),
        _ => panic!("no source column"),
    };
    let kept = match vectors.column("kept") {
        Some(ColumnData::Bool(kept)) => kept.clone(),
        _ => panic!("no kept column"),
    };
    let remaining = f64_column(vectors, "remaining");
    for (k, source) in source.iter().enumerate() {
        if source == "real" {
            assert_eq!(
                kept[k],
                remaining[k] >= COMPLETION_FRACTION,
                "candidate {k}"
            );
        }
    }
}

#[test]
fn the_residual_indicator_tracks_the_true_error_and_the_adaptive_basis_meets_its_target() {
    let inputs = brake_inputs();
    let tau = 2.0 * PI / most_unstable(&inputs).im / 40.0;
    let (duration, amplitude) = (400.0 * tau, 1e-4);
    let params = transient_params(&[
        ("tau", Value::Float(tau)),
        ("duration", Value::Float(duration)),
        ("amplitude", Value::Float(amplitude)),
    ]);
    let full = Transient.run(&params, &inputs).unwrap();
    let full_history = full["history"].as_table().unwrap().clone();
    // (indicator, true error: the largest relative difference of the contact averages and
    // the kinetic energy from the full run's)
    let run = |basis: &Outputs| {
        let mut inputs = inputs.clone();
        insert(&mut inputs, "basis", basis["basis"].clone());
        let outputs = Transient.run(&params, &inputs).unwrap();
        let summary = outputs["summary"].as_table().unwrap();
        let error = relative_difference(
            outputs["history"].as_table().unwrap(),
            &full_history,
            &["u_t", "v_t", "kinetic"],
        );
        (quantity(summary, "residual_indicator"), error)
    };
    let mut results: Vec<(f64, f64)> = [2, 6, 0]
        .iter()
        .map(|&n| run(&fc_basis(&inputs, &[("n_modes", Value::Int(n))])))
        .collect();
    let adaptive = fc_basis(
        &inputs,
        &[
            ("kind", Value::Str("adaptive".into())),
            ("n_modes", Value::Int(2)),
            ("target", Value::Float(0.02)),
            ("probe_tau", Value::Float(tau)),
            ("probe_duration", Value::Float(duration)),
            ("probe_amplitude", Value::Float(amplitude)),
        ],
    );
    results.push(run(&adaptive));
    // The indicator orders the bases as their true errors do, and estimates them within a
    // common factor (about 3 here: η measures one step's defect, the error accumulates).
    let mut by_indicator = results.clone();
    by_indicator.sort_by(|a, b| a.0.total_cmp(&b.0));
    assert!(
        by_indicator.windows(2).all(|pair| pair[0].1 < pair[1].1),
        "(indicator, true error) per basis: {results:?}"
    );
    let ratios: Vec<f64> = results.iter().map(|(eta, error)| error / eta).collect();
    let spread = ratios.iter().copied().fold(0.0, f64::max)
        / ratios.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(spread < 2.0, "error over indicator per basis: {ratios:?}");
    // The adaptive basis starts from FC_2, meets its target, and its run reports the
    // indicator of its last round.
    let rounds = f64_column(adaptive["rounds"].as_table().unwrap(), "indicator");
    assert_eq!(rounds[0], results[0].0, "round 1 is FC_2's probe");
    assert!(
        rounds.windows(2).all(|pair| pair[1] < pair[0]),
        "{rounds:?}"
    );
    let last = *rounds.last().unwrap();
    assert!(last <= 0.02 && rounds.len() >= 2, "{rounds:?}");
    assert!(
        (results[3].0 - last).abs() <= 1e-9 * last,
        "{} against {last}",
        results[3].0
    );
    let summary = adaptive["summary"].as_table().unwrap();
    assert_eq!(quantity(summary, "indicator"), last);
    // Residual vectors may bring as little as rank_tolerance of their norm that is new: their
    // orthonormalisation costs a digit more than the modes'.
    let orthonormality = quantity(summary, "orthonormality_error");
    assert!(orthonormality < 1e-11, "{orthonormality:.2e}");
    assert!(
        results[3].1 < results[2].1,
        "adaptive beats the default FC: {results:?}"
    );
}

#[test]
fn basis_outputs_do_not_depend_on_the_thread_count() {
    let mut inputs = brake_inputs();
    let modes = real_modes(&inputs, 12, 0.0);
    insert(&mut inputs, "modes", modes);
    for overrides in [
        vec![],
        vec![
            ("kind", Value::Str("real".into())),
            ("n_modes", Value::Int(8)),
        ],
        vec![
            ("kind", Value::Str("craig_bampton".into())),
            ("n_modes", Value::Int(8)),
        ],
        vec![
            ("kind", Value::Str("adaptive".into())),
            ("n_modes", Value::Int(2)),
            ("target", Value::Float(0.05)),
            ("probe_duration", Value::Float(1e-4)),
        ],
    ] {
        let params = Params::defaults(&ReductionBasis, &overrides);
        crate::stage::assert_outputs_independent_of_threads(
            &ReductionBasis,
            &params,
            &inputs,
            &format!("basis {overrides:?}"),
        );
    }
}

/// With the pads kept whole, the reduced `J` is one dense block per body. A kicked run (pairs
/// opening and closing) solved by the inverses of those blocks agrees with the same run
/// solved by `J`'s factor to 1e-11 (the runs differ by rounding alone), and both close the
/// energy balance to round-off.
#[test]
fn a_reduced_run_by_the_inverse_of_its_blocks_agrees_with_one_by_the_factor() {
    use crate::transient::scheme::{HistoryRow, Settings, SolveBy};
    use crate::transient::{contact::Solver, kick, run_reduced, structure_of};

    let inputs = brake_inputs();
    let model: &Model = inputs.get("model").unwrap();
    let equilibrium: &Equilibrium = inputs.get("equilibrium").unwrap();
    let disc = components(&[&model.M, &model.C, &model.K])
        .iter()
        .map(Vec::len)
        .max()
        .unwrap();
    let whole = fc_basis(
        &inputs,
        &[
            ("n_modes", Value::Int(4)),
            ("keep_whole_up_to", Value::Int(disc as i64 - 1)),
        ],
    );
    let Artifact::Basis(basis) = &whole["basis"] else {
        panic!("not a basis")
    };
    let (structure, contact_state) = structure_of(model, equilibrium).unwrap();
    let n_steps = 300;
    let run = |solve_by: SolveBy| {
        let settings = Settings {
            theta: 0.5,
            tau: 2e-6,
            n_steps,
            solver: Solver::ActiveSet,
            tolerance: 1e-12,
            max_iterations: 2000,
            output_every: 1,
            record_pairs: Vec::new(),
            record_dofs: Vec::new(),
            record_contacts: false,
            snapshot_steps: vec![n_steps / 2, n_steps],
            sample_steps: Vec::new(),
            solve_by,
        };
        run_reduced(
            model,
            (&structure, &contact_state),
            basis,
            &settings,
            kick(model, equilibrium, 1.0),
            &RunContext::detached(),
        )
        .unwrap()
    };
    let (by_inverse, by_factor) = (run(SolveBy::Inverse), run(SolveBy::Factor));
    assert!(by_inverse.by_inverse && !by_factor.by_inverse);
    let opened = by_factor.history.iter().any(|row| row.open > 0.0);
    assert!(opened, "the kick opens pairs");
    let worst = |value: fn(&HistoryRow) -> f64| {
        let scale = by_factor
            .history
            .iter()
            .map(|row| value(row).abs())
            .fold(0.0, f64::max);
        let gap = by_inverse
            .history
            .iter()
            .zip(&by_factor.history)
            .map(|(a, b)| (value(a) - value(b)).abs())
            .fold(0.0, f64::max);
        gap / scale
    };
    for (name, value) in [
        ("u_n", (|row| row.u_n) as fn(&HistoryRow) -> f64),
        ("v_n", |row| row.v_n),
        ("v_t", |row| row.v_t),
        ("kinetic", |row| row.kinetic),
    ] {
        let gap = worst(value);
        assert!(
            gap < 1e-11,
            "{name}: by the inverse against the factor {gap:.2e}"
        );
    }
    for (a, b) in by_inverse.snapshots.iter().zip(&by_factor.snapshots) {
        let scale = b.v.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let gap =
            a.v.iter()
                .zip(&b.v)
                .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(
            gap < 1e-11 * scale,
            "snapshot at {}: {gap:.2e} of {scale:.2e}",
            b.t
        );
    }
    for run in [&by_inverse, &by_factor] {
        let last = &run.history.last().unwrap().energy;
        let peak = run
            .history
            .iter()
            .map(|row| row.energy.kinetic + row.energy.strain)
            .fold(0.0, f64::max);
        assert!(
            last.balance_error.abs() < 1e-10 * peak,
            "balance {:.2e} of {peak:.2e} (by the inverse: {})",
            last.balance_error,
            run.by_inverse
        );
    }
}

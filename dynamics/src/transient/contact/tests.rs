use std::ops::Range;

use faer::Mat;

use super::active_set::REFACTORISE_AFTER;
use super::anderson::Anderson;
use super::iterative::LARGEST_BLOCK;
use super::laws::pair;
use super::*;

/// A solve as the scheme makes it: a solution found in single precision is settled on
/// its exact velocities `w_free + W r`, or refined in double precision.
fn solve_settled(
    solver: &mut ContactSolver,
    problem: &Problem,
    tolerance: f64,
    max_iterations: usize,
    r: &mut [f64],
    w: &mut [f64],
) -> Result<Report, NotConverged> {
    let mut report = solver.solve(problem, tolerance, max_iterations, r, w)?;
    if report.precision == Precision::Single {
        velocities(problem.W, problem.w_free, r, w);
        match solver.settle(problem, tolerance, r, w) {
            Ok(residual) => report.residual = residual,
            Err(_) => {
                let refined = solver.refine(problem, tolerance, max_iterations, r, w)?;
                report.iterations += refined.iterations;
                report.residual = refined.residual;
            }
        }
    }
    Ok(report)
}

/// The six pairs of [`problem_data`] as two pads of three.
fn two_pads() -> Vec<Range<usize>> {
    pad_blocks(&[7, 7, 7, 2, 2, 2])
}

/// A small coupled problem: pairs sharing compliance through off-diagonal terms.
fn problem_data(n_pairs: usize) -> (Mat<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
    let m = 3 * n_pairs;
    let B = Mat::from_fn(m, m, |i, j| {
        let x = ((i * 7 + j * 13) % 11) as f64 / 11.0 - 0.5;
        if i == j { 2.0 + x } else { 0.3 * x }
    });
    let W = B.transpose() * &B;
    // Some pairs pressed (negative free normal velocity), some leaving.
    let w_free: Vec<f64> = (0..m)
        .map(|i| match i % 3 {
            0 => {
                if (i / 3) % 3 == 2 {
                    0.5
                } else {
                    -1.0
                }
            }
            1 => 0.2 * ((i / 3) as f64 - 1.0),
            _ => 0.1,
        })
        .collect();
    let w_n_min = vec![0.0; n_pairs];
    let sliding = vec![1.0; n_pairs];
    (W, w_free, w_n_min, sliding)
}

fn solve_with(solver: Solver, mu: f64) -> (Vec<f64>, Vec<f64>, Report) {
    let n_pairs = 6;
    let (W, w_free, w_n_min, sliding) = problem_data(n_pairs);
    let problem = Problem {
        W: &Delassus::new(W.clone()),
        w_free: &w_free,
        w_n_min: &w_n_min,
        sliding_speed: &sliding,
        speed_scale: 0.0,
        mu: &vec![mu; sliding.len()],
        force_scale: 0.0,
        blocks: &two_pads(),
    };
    let mut r = vec![0.0; 3 * n_pairs];
    let mut w = vec![0.0; 3 * n_pairs];
    let report = solve_settled(
        &mut ContactSolver::new(solver),
        &problem,
        1e-13,
        20_000,
        &mut r,
        &mut w,
    )
    .unwrap();
    (r, w, report)
}

/// Checks every law on the solution, to `tolerance` in forces and velocities.
fn check_laws(r: &[f64], w: &[f64], mu: f64, tolerance: f64) {
    for p in 0..r.len() / 3 {
        let (r_p, w_p) = (pair(r, p), pair(w, p));
        assert!(
            r_p[0] >= 0.0 && w_p[0] >= -tolerance,
            "pair {p}: {r_p:?} {w_p:?}"
        );
        assert!(
            (r_p[0] * w_p[0]).abs() < tolerance,
            "complementarity at pair {p}"
        );
        let r_T = r_p[1].hypot(r_p[2]);
        assert!(r_T <= mu * r_p[0] * (1.0 + 1e-12) + tolerance);
        let slip = [w_p[1] - 1.0, w_p[2]];
        let slip_speed = slip[0].hypot(slip[1]);
        if slip_speed > tolerance {
            // Sliding: on the cone's edge, against the slip.
            assert!((r_T - mu * r_p[0]).abs() < tolerance * 10.0, "pair {p}");
            let alignment = (r_p[1] * slip[0] + r_p[2] * slip[1]) / (r_T * slip_speed);
            assert!(
                r_T == 0.0 || alignment < -1.0 + 1e-8,
                "pair {p}: {alignment}"
            );
        }
    }
}

#[test]
fn both_solvers_satisfy_the_laws_and_agree() {
    for mu in [0.0, 0.38, 1.2] {
        let (r_gs, w_gs, report_gs) = solve_with(Solver::GaussSeidel, mu);
        let (r_fp, w_fp, report_fp) = solve_with(Solver::FixedPoint, mu);
        check_laws(&r_gs, &w_gs, mu, 1e-10);
        check_laws(&r_fp, &w_fp, mu, 1e-10);
        for (a, b) in r_gs.iter().zip(&r_fp) {
            assert!((a - b).abs() < 1e-9, "mu = {mu}: {a} vs {b}");
        }
        assert!(
            report_gs.iterations <= report_fp.iterations,
            "mu = {mu}: Gauss-Seidel {} sweeps, fixed point {}",
            report_gs.iterations,
            report_fp.iterations
        );
    }
}

/// Passes in single precision leave `w` off the exact `w_free + W r` by rounding: a
/// loose tolerance is still met on the exact velocities; one below that error (1e-9
/// here) is refused, refined in double precision to the tolerance, and the next step
/// solved in double. Tolerances below the least tried are solved in double at once.
#[test]
fn single_precision_solutions_are_settled_on_exact_velocities_or_refined() {
    let n_pairs = 6;
    let (W, w_free, w_n_min, sliding) = problem_data(n_pairs);
    let W = Delassus::new(W);
    let blocks = two_pads();
    let problem = Problem {
        W: &W,
        w_free: &w_free,
        w_n_min: &w_n_min,
        sliding_speed: &sliding,
        speed_scale: 0.0,
        mu: &vec![0.38; sliding.len()],
        force_scale: 0.0,
        blocks: &blocks,
    };
    let m = 3 * n_pairs;
    let exact = |r: &[f64]| {
        let mut w = vec![0.0; m];
        velocities(problem.W, problem.w_free, r, &mut w);
        w
    };
    let distance = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
    };
    for (tolerance, met_in_single) in [(1e-6, true), (1e-9, false)] {
        let mut solver = ContactSolver::new(Solver::GaussSeidel);
        let (mut r, mut w) = (vec![0.0; m], vec![0.0; m]);
        let report = solver
            .solve(&problem, tolerance, 20_000, &mut r, &mut w)
            .unwrap();
        assert_eq!(report.precision, Precision::Single);
        let drift = distance(&w, &exact(&r));
        assert!(
            drift > 0.0 && drift < 1e-6,
            "single-precision drift {drift}"
        );
        let w_exact = exact(&r);
        match solver.settle(&problem, tolerance, &r, &w_exact) {
            Ok(residual) => {
                assert!(
                    met_in_single,
                    "tolerance {tolerance}: settled at {residual}"
                );
                assert!(residual <= tolerance);
            }
            Err(residual) => {
                assert!(
                    !met_in_single,
                    "tolerance {tolerance}: refused at {residual}"
                );
                assert!(
                    residual > tolerance && residual < 1e-6,
                    "refused at {residual}"
                );
                let mut w = w_exact;
                let refined = solver
                    .refine(&problem, tolerance, 20_000, &mut r, &mut w)
                    .unwrap();
                assert!(refined.residual <= tolerance);
                assert_eq!(refined.precision, Precision::Double);
                assert!(distance(&w, &exact(&r)) < 1e-14, "refined in double");
                check_laws(&r, &w, 0.38, 1e-8);
                let next = solver
                    .solve(&problem, tolerance, 20_000, &mut r, &mut w)
                    .unwrap();
                assert_eq!(next.precision, Precision::Double);
            }
        }
    }
    let (mut r, mut w) = (vec![0.0; m], vec![0.0; m]);
    let tight = ContactSolver::new(Solver::GaussSeidel)
        .solve(&problem, 1e-12, 20_000, &mut r, &mut w)
        .unwrap();
    assert_eq!(tight.precision, Precision::Double);
}

#[test]
fn the_active_set_solver_reuses_its_factorisation_and_agrees_with_gauss_seidel() {
    let n_pairs = 6;
    let (W, w_free, w_n_min, sliding) = problem_data(n_pairs);
    for mu in [0.0, 0.38, 1.2] {
        let (r_gs, _, _) = solve_with(Solver::GaussSeidel, mu);
        let mut solver = ContactSolver::new(Solver::ActiveSet);
        let mut r = vec![0.0; 3 * n_pairs];
        let mut w = vec![0.0; 3 * n_pairs];
        // A slowly drifting problem: the set holds, the sliding directions turn.
        for step in 0..6 {
            let drifted: Vec<f64> = w_free
                .iter()
                .enumerate()
                .map(|(i, value)| value + 1e-5 * step as f64 * ((i % 5) as f64 - 2.0))
                .collect();
            let problem = Problem {
                W: &Delassus::new(W.clone()),
                w_free: &drifted,
                w_n_min: &w_n_min,
                sliding_speed: &sliding,
                speed_scale: 0.0,
                mu: &vec![mu; sliding.len()],
                force_scale: 0.0,
                blocks: &two_pads(),
            };
            let report =
                solve_settled(&mut solver, &problem, 1e-13, 20_000, &mut r, &mut w).unwrap();
            check_laws(&r, &w, mu, 1e-10);
            if step == 0 {
                for (a, b) in r.iter().zip(&r_gs) {
                    assert!((a - b).abs() < 1e-9, "mu = {mu}: {a} vs {b}");
                }
            }
            // Gauss–Seidel on the first two steps, then the chord on the factorisation.
            if step >= 2 {
                assert!(
                    solver.factorisation.is_some() && report.iterations <= REFACTORISE_AFTER,
                    "mu = {mu}, step {step}: {} iterations",
                    report.iterations
                );
            }
        }
        // A jump that changes the set: solved all the same, by the fallback.
        let reversed: Vec<f64> = w_free.iter().map(|value| -value).collect();
        let problem = Problem {
            W: &Delassus::new(W.clone()),
            w_free: &reversed,
            w_n_min: &w_n_min,
            sliding_speed: &sliding,
            speed_scale: 0.0,
            mu: &vec![mu; sliding.len()],
            force_scale: 0.0,
            blocks: &two_pads(),
        };
        solve_settled(&mut solver, &problem, 1e-13, 20_000, &mut r, &mut w).unwrap();
        check_laws(&r, &w, mu, 1e-10);
        // The memory a checkpoint keeps rebuilds the same solver.
        let mut restored = ContactSolver::new(Solver::ActiveSet);
        restored.restore(solver.memory(), &problem);
        assert_eq!(restored.memory(), solver.memory());
    }
}

#[test]
fn factorisations_that_do_not_pay_for_themselves_become_rare() {
    // Sets that hold two steps, then change: each factorisation fails on its first use,
    // and the waits between them double.
    let n_pairs = 6;
    let (W, w_free, w_n_min, sliding) = problem_data(n_pairs);
    let reversed: Vec<f64> = w_free.iter().map(|value| -value).collect();
    let mut solver = ContactSolver::new(Solver::ActiveSet);
    let (mut r, mut w) = (vec![0.0; 3 * n_pairs], vec![0.0; 3 * n_pairs]);
    let steps = 600;
    for step in 0..steps {
        let problem = Problem {
            W: &Delassus::new(W.clone()),
            w_free: if (step / 3) % 2 == 0 {
                &w_free
            } else {
                &reversed
            },
            w_n_min: &w_n_min,
            sliding_speed: &sliding,
            speed_scale: 0.0,
            mu: &vec![0.38; sliding.len()],
            force_scale: 0.0,
            blocks: &two_pads(),
        };
        solve_settled(&mut solver, &problem, 1e-13, 20_000, &mut r, &mut w).unwrap();
        check_laws(&r, &w, 0.38, 1e-10);
    }
    // Unpaced, one factorisation every three steps (200); paced, the waits 2, 4, …, 256
    // leave about a dozen.
    assert!(
        solver.factorisations <= 12,
        "{} factorisations in {steps} steps",
        solver.factorisations
    );
}

#[test]
fn a_pressed_single_pair_sticks_or_slides_as_coulomb_says() {
    // W = I: w = w_free + r. Pressed (w_free,n = −1) ⇒ r_n = 1. Free slip w_t − v_g =
    // −0.5: sticking needs r_t = 0.5, allowed when μ ≥ 0.5.
    let W = Mat::<f64>::identity(3, 3);
    for (mu, expected_r_t) in [(0.8, 0.5), (0.3, 0.3)] {
        let problem = Problem {
            W: &Delassus::new(W.clone()),
            w_free: &[-1.0, 0.5, 0.0],
            w_n_min: &[0.0],
            sliding_speed: &[1.0],
            speed_scale: 0.0,
            mu: &[mu],
            force_scale: 1.0,
            blocks: &pad_blocks(&[0]),
        };
        let (mut r, mut w) = (vec![0.0; 3], vec![0.0; 3]);
        solve_settled(
            &mut ContactSolver::new(Solver::GaussSeidel),
            &problem,
            1e-14,
            100,
            &mut r,
            &mut w,
        )
        .unwrap();
        assert!((r[0] - 1.0).abs() < 1e-14);
        assert!((r[1] - expected_r_t).abs() < 1e-14, "mu = {mu}: {r:?}");
        assert!(r[2].abs() < 1e-14);
    }
}

/// On an affine contraction `g = B x + c` (a sweep while the pairs keep their states),
/// Anderson mixing reaches the fixed point in a fraction of the plain iterations, and the
/// velocities it combines stay those of the combined reactions, `w = W_0 r + w_0`.
#[test]
fn anderson_mixing_accelerates_an_affine_iteration_and_keeps_the_velocities() {
    let n = 30;
    // Spectral radius 0.9: plain iteration needs about 260 iterations to gain 1e-12.
    let B = Mat::from_fn(n, n, |i, j| {
        let x = ((i * 5 + j * 3) % 7) as f64 / 7.0 - 0.5;
        if i == j { 0.9 } else { 0.004 * x }
    });
    let c: Vec<f64> = (0..n).map(|i| (i % 4) as f64 - 1.5).collect();
    let W_0 = Mat::from_fn(n, n, |i, j| 1.0 / (1.0 + (i as f64 - j as f64).abs()));
    let w_0: Vec<f64> = (0..n).map(|i| 0.1 * i as f64).collect();
    let apply = |A: &Mat<f64>, x: &[f64], shift: &[f64]| -> Vec<f64> {
        (0..n)
            .map(|i| shift[i] + (0..n).map(|j| A[(i, j)] * x[j]).sum::<f64>())
            .collect()
    };
    let iterations = |accelerate: bool| {
        let mut anderson = Anderson::new(n);
        let mut r = vec![0.0; n];
        for iteration in 1..=1000 {
            anderson.start(&r);
            let g = apply(&B, &r, &c);
            let change = g
                .iter()
                .zip(&r)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            if change < 1e-12 {
                return iteration;
            }
            r = g;
            let mut w = apply(&W_0, &r, &w_0);
            if accelerate {
                anderson.mix(&mut r, &mut w);
            }
            let exact = apply(&W_0, &r, &w_0);
            for (mixed, exact) in w.iter().zip(&exact) {
                assert!((mixed - exact).abs() < 1e-11, "{mixed} vs {exact}");
            }
        }
        panic!("no convergence");
    };
    let (plain, accelerated) = (iterations(false), iterations(true));
    assert!(plain > 200, "plain iteration: {plain}");
    assert!(
        5 * accelerated < plain,
        "{accelerated} against {plain} plain"
    );
}

/// Pairs on one pad couple through it far more than through the disc: sweeping each pad's
/// pairs together reaches the same solution with a fraction of the sweeps over `W`.
#[test]
fn gauss_seidel_by_pads_agrees_with_pair_by_pair_in_fewer_sweeps() {
    let (n_pads, per_pad) = (4, 4);
    let (n_pairs, m) = (n_pads * per_pad, 3 * n_pads * per_pad);
    let pad = |i: usize| i / (3 * per_pad);
    let W = Mat::from_fn(m, m, |i, j| {
        let within = if i == j {
            1.0
        } else if pad(i) == pad(j) {
            0.3
        } else {
            0.0
        };
        // A weak coupling of every pair through the disc, positive semi-definite.
        let g = |k: usize| 1.0 + 0.5 * ((k * 7) % 5) as f64;
        within + 0.01 * g(i) * g(j)
    });
    let w_free: Vec<f64> = (0..m)
        .map(|i| match i % 3 {
            0 => -1.0 - 0.1 * (i % 4) as f64,
            1 => 0.1 * (i % 5) as f64 - 0.2,
            _ => 0.05,
        })
        .collect();
    let (w_n_min, sliding) = (vec![0.0; n_pairs], vec![1.0; n_pairs]);
    let solve = |body_of_pair: &[usize]| {
        let blocks = pad_blocks(body_of_pair);
        let problem = Problem {
            W: &Delassus::new(W.clone()),
            w_free: &w_free,
            w_n_min: &w_n_min,
            sliding_speed: &sliding,
            speed_scale: 0.0,
            mu: &vec![0.38; sliding.len()],
            force_scale: 0.0,
            blocks: &blocks,
        };
        let (mut r, mut w) = (vec![0.0; m], vec![0.0; m]);
        let report = solve_settled(
            &mut ContactSolver::new(Solver::GaussSeidel),
            &problem,
            1e-13,
            20_000,
            &mut r,
            &mut w,
        )
        .unwrap();
        check_laws(&r, &w, 0.38, 1e-10);
        (r, report.iterations, blocks.len())
    };
    let by_pad: Vec<usize> = (0..n_pairs).map(|p| p / per_pad).collect();
    let by_pair: Vec<usize> = (0..n_pairs).collect();
    let ((r_pads, sweeps_pads, n_blocks), (r_pairs, sweeps_pairs, n_singletons)) =
        (solve(&by_pad), solve(&by_pair));
    assert_eq!((n_blocks, n_singletons), (n_pads, n_pairs));
    for (a, b) in r_pads.iter().zip(&r_pairs) {
        assert!((a - b).abs() < 1e-10, "{a} vs {b}");
    }
    assert!(
        2 * sweeps_pads <= sweeps_pairs,
        "{sweeps_pads} sweeps by pads, {sweeps_pairs} pair by pair"
    );
}

#[test]
fn blocks_are_runs_of_one_body_and_no_longer_than_the_largest() {
    assert_eq!(pad_blocks(&[3, 3, 1, 1, 1, 3]), [0..2, 2..5, 5..6]);
    let long = pad_blocks(&[0; 2 * LARGEST_BLOCK + 1]);
    assert_eq!(
        long,
        [
            0..LARGEST_BLOCK,
            LARGEST_BLOCK..2 * LARGEST_BLOCK,
            2 * LARGEST_BLOCK..2 * LARGEST_BLOCK + 1
        ]
    );
}

#[test]
fn a_solve_that_cannot_converge_reports_its_residuals() {
    let (W, w_free, w_n_min, sliding) = problem_data(6);
    let problem = Problem {
        W: &Delassus::new(W.clone()),
        w_free: &w_free,
        w_n_min: &w_n_min,
        sliding_speed: &sliding,
        speed_scale: 0.0,
        mu: &vec![0.38; sliding.len()],
        force_scale: 0.0,
        blocks: &two_pads(),
    };
    let (mut r, mut w) = (vec![0.0; 18], vec![0.0; 18]);
    let failure = solve_settled(
        &mut ContactSolver::new(Solver::FixedPoint),
        &problem,
        1e-15,
        2,
        &mut r,
        &mut w,
    )
    .unwrap_err();
    assert_eq!(failure.iterations, 2);
    assert_eq!(failure.history.len(), 2);
    assert!(failure.history.iter().all(|residual| *residual > 1e-15));
}

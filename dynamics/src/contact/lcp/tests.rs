use super::*;

/// Reactions non-negative, penetrations within the tolerance (as forces), complementary.
fn check_solution(a: &Mat<f64>, q: &[f64], solution: &LcpSolution) {
    let largest = solution.r.iter().fold(0.0f64, |max, r| max.max(*r));
    for i in 0..q.len() {
        assert!(solution.r[i] >= 0.0, "r[{i}] = {}", solution.r[i]);
        assert!(
            solution.g[i] / a[(i, i)] >= -1e-10 * largest,
            "g[{i}] = {}",
            solution.g[i]
        );
    }
    assert!(complementarity_residual(a, q, &solution.r, &solution.g) <= 1e-10);
}

/// A small symmetric positive definite operator with off-diagonal coupling.
fn spd(n: usize) -> Mat<f64> {
    Mat::from_fn(n, n, |i, j| {
        if i == j {
            4.0
        } else {
            1.0 / (1.0 + (i as f64 - j as f64).abs())
        }
    })
}

#[test]
fn both_solvers_agree_on_a_mixed_open_and_closed_problem() {
    let a = spd(8);
    let q: Vec<f64> = (0..8)
        .map(|i| {
            if i % 3 == 0 {
                0.5
            } else {
                -1.0 - i as f64 * 0.1
            }
        })
        .collect();
    let newton = semismooth_newton(&a, &q, &LcpSettings::default()).unwrap();
    let fixed = fixed_point(
        &a,
        &q,
        &LcpSettings {
            relaxation: 0.5,
            ..LcpSettings::default()
        },
    )
    .unwrap();
    check_solution(&a, &q, &newton);
    check_solution(&a, &q, &fixed);
    for i in 0..8 {
        assert!(
            (newton.r[i] - fixed.r[i]).abs()
                <= 1e-9 * newton.r.iter().fold(0.0f64, |m, v| m.max(*v))
        );
    }
    assert!(newton.iterations <= 5, "{} iterations", newton.iterations);
    assert!(newton.r.contains(&0.0) && newton.r.iter().any(|r| *r > 0.0));
}

#[test]
fn one_spring_pressed_by_an_interference_has_the_closed_form_force() {
    // A pad of stiffness k pressed by an interference δ: r = k δ, g = 0.
    let (k, delta) = (2.0e7, 1.0e-4);
    let a = Mat::from_fn(1, 1, |_, _| 1.0 / k);
    let q = [-delta];
    for solution in [
        semismooth_newton(&a, &q, &LcpSettings::default()).unwrap(),
        fixed_point(&a, &q, &LcpSettings::default()).unwrap(),
    ] {
        assert!((solution.r[0] - k * delta).abs() <= 1e-9 * k * delta);
        assert!(solution.g[0].abs() <= 1e-15);
    }
    let open = semismooth_newton(&a, &[delta], &LcpSettings::default()).unwrap();
    assert_eq!(open.r, [0.0]);
}

#[test]
fn a_nonconverging_fixed_point_reports_its_residual_history() {
    // Over-relaxed Jacobi on a strongly coupled operator diverges.
    let a = Mat::from_fn(4, 4, |i, j| if i == j { 1.0 } else { 0.9 });
    let q = [-1.0; 4];
    let settings = LcpSettings {
        relaxation: 1.9,
        max_iterations: 50,
        ..LcpSettings::default()
    };
    let err = fixed_point(&a, &q, &settings).unwrap_err();
    let message = err.to_string();
    assert!(
        message.starts_with("fixed point did not converge in"),
        "{message}"
    );
    assert!(message.contains("last residuals:"), "{message}");
    assert!(semismooth_newton(&a, &q, &LcpSettings::default()).is_ok());
}

#[test]
fn a_non_positive_diagonal_is_named_as_a_loss_of_uniqueness() {
    // Friction outweighing the normal stiffness at pair 1: A_11 = 1 − 1.5.
    let a = Mat::from_fn(2, 2, |i, j| match (i, j) {
        (0, 0) => 1.0,
        (1, 1) => -0.5,
        _ => 0.2,
    });
    let q = [-1.0, -1.0];
    for err in [
        fixed_point(&a, &q, &LcpSettings::default()).unwrap_err(),
        semismooth_newton(&a, &q, &LcpSettings::default()).unwrap_err(),
    ] {
        assert_eq!(err.non_positive_diagonal, Some((1, -0.5)));
        let message = err.to_string();
        assert!(
            message.contains("A[1,1] = -5.000e-1 <= 0 at pair 1")
                && message.contains("not unique, or does not exist")
                && !message.contains("inf"),
            "{message}"
        );
    }
}

/// Eight pairs on one floating body pressed by a load P: a translation toward the disc
/// (B column −1) and a tilt; C ≠ B as friction makes it.
fn balanced_problem() -> (Mat<f64>, Vec<f64>, Balance) {
    let n = 8;
    let a = spd(n);
    let q: Vec<f64> = (0..n).map(|i| 0.1 * (i as f64 - 3.0)).collect();
    let lever = |i: usize| (i as f64 - 3.5) / 3.5;
    let B = Mat::from_fn(n, 2, |i, j| if j == 0 { -1.0 } else { -lever(i) });
    let C = Mat::from_fn(n, 2, |i, j| B[(i, j)] + if j == 1 { -0.1 } else { 0.0 });
    // Load 10 along the translation, and a moment that lifts one end.
    let balance = Balance {
        B,
        C,
        d: vec![-10.0, 4.0],
    };
    (a, q, balance)
}

#[test]
fn both_solvers_agree_on_a_balanced_problem_with_a_lifted_end() {
    let (a, q, balance) = balanced_problem();
    let newton = semismooth_newton_balanced(&a, &q, &balance, &LcpSettings::default()).unwrap();
    let fixed = fixed_point_balanced(
        &a,
        &q,
        &balance,
        &LcpSettings {
            relaxation: 0.5,
            max_iterations: 100_000,
            ..LcpSettings::default()
        },
    )
    .unwrap();
    for solution in [&newton, &fixed] {
        check_solution(&a, &q, solution);
        assert!(balance.residual(&solution.r) <= 1e-10);
        let total: f64 = (0..8).map(|i| -balance.C[(i, 0)] * solution.r[i]).sum();
        assert!((total - 10.0).abs() <= 1e-10 * 10.0, "{total}");
    }
    let largest = newton.r.iter().fold(0.0f64, |m, v| m.max(*v));
    for i in 0..8 {
        assert!((newton.r[i] - fixed.r[i]).abs() <= 1e-9 * largest);
    }
    for j in 0..2 {
        assert!((newton.a[j] - fixed.a[j]).abs() <= 1e-8 * newton.a[0].abs());
    }
    // The moment opens part of the face.
    assert!(newton.r.contains(&0.0) && newton.r.iter().any(|r| *r > 0.0));
    assert!(newton.iterations <= 6, "{} iterations", newton.iterations);
}

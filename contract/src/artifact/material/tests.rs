//! Orthotropic elasticity against closed forms: the isotropic case, `D S = I`, a quarter turn
//! that swaps axes 1 and 2, invariance of isotropy under any rotation and of transverse
//! isotropy about its axis, the frames' axes, and constants that are not a material.

use super::*;

/// Largest difference between two matrices, relative to the largest entry of `b`.
fn distance(a: &Elasticity, b: &Elasticity) -> f64 {
    let scale = b.iter().flatten().fold(0.0_f64, |m, v| m.max(v.abs()));
    let worst = a
        .iter()
        .flatten()
        .zip(b.iter().flatten())
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()));
    worst / scale
}

/// A lining-like material: soft and anisotropic, every constant different.
fn lining() -> EngineeringConstants {
    EngineeringConstants {
        youngs_moduli: [9.0e9, 7.0e9, 3.0e9],
        poisson_ratios: [0.25, 0.12, 0.18],
        shear_moduli: [3.1e9, 1.4e9, 1.1e9],
    }
}

/// A rotation from three angles (z, then x, then z).
fn rotation(a: f64, b: f64, c: f64) -> [[f64; 3]; 3] {
    let rz = |t: f64| {
        [
            [t.cos(), t.sin(), 0.0],
            [-t.sin(), t.cos(), 0.0],
            [0.0, 0.0, 1.0],
        ]
    };
    let rx = |t: f64| {
        [
            [1.0, 0.0, 0.0],
            [0.0, t.cos(), t.sin()],
            [0.0, -t.sin(), t.cos()],
        ]
    };
    let product = |p: [[f64; 3]; 3], q: [[f64; 3]; 3]| {
        let mut r = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                r[i][j] = (0..3).map(|k| p[i][k] * q[k][j]).sum();
            }
        }
        r
    };
    product(rz(c), product(rx(b), rz(a)))
}

#[test]
fn isotropic_constants_give_the_isotropic_law() {
    // Tolerance 1e-14 relative: the same numbers by two formulas.
    let (E, nu) = (2.1e11, 0.29);
    let isotropic = isotropic_elasticity(E, nu);
    let from_constants = EngineeringConstants::isotropic(E, nu).material_elasticity();
    assert!(distance(&from_constants, &isotropic) < 1e-14);
    let transverse =
        EngineeringConstants::transversely_isotropic((E, nu), E, nu, E / (2.0 * (1.0 + nu)));
    assert!(transverse.is_transversely_isotropic());
    assert!(distance(&transverse.material_elasticity(), &isotropic) < 1e-14);
}

#[test]
fn the_elasticity_inverts_the_compliance() {
    // A unit stress along each Voigt component, strained by S as the module doc writes it
    // (ν_21 = ν_12 E_2/E_1 read from the symmetric S), gives back the stress: 1e-14.
    let c = lining();
    let [E1, E2, E3] = c.youngs_moduli;
    let [nu12, nu13, nu23] = c.poisson_ratios;
    let [G12, G13, G23] = c.shear_moduli;
    let S = [
        [1.0 / E1, -nu12 / E1, -nu13 / E1, 0.0, 0.0, 0.0],
        [-nu12 / E1, 1.0 / E2, -nu23 / E2, 0.0, 0.0, 0.0],
        [-nu13 / E1, -nu23 / E2, 1.0 / E3, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 1.0 / G12, 0.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, 1.0 / G23, 0.0],
        [0.0, 0.0, 0.0, 0.0, 0.0, 1.0 / G13],
    ];
    let D = c.material_elasticity();
    for (i, row) in D.iter().enumerate() {
        for k in 0..6 {
            let stress: f64 = row.iter().zip(&S).map(|(d, s)| d * s[k]).sum();
            let expected = if i == k { 1.0 } else { 0.0 };
            assert!(
                (stress - expected).abs() < 1e-14,
                "(D S)[{i}][{k}] = {stress}"
            );
        }
    }
}

#[test]
fn a_quarter_turn_about_axis_3_swaps_axes_1_and_2() {
    // Axis 1 along y: the global D is that of the constants with 1 and 2 exchanged
    // (ν'_12 = ν_21 = ν_12 E_2/E_1, ν'_13 = ν_23, G'_13 = G_23, …): 1e-13 relative.
    let c = lining();
    let frame = Frame::Axes {
        axis1: [0.0, 1.0, 0.0],
        axis3: [0.0, 0.0, 1.0],
    };
    frame.check("lining", &c).unwrap();
    let axes = frame.axes_at([0.3, -0.2, 0.1]).unwrap();
    let rotated = to_global(&c.material_elasticity(), &axes);
    let [E1, E2, E3] = c.youngs_moduli;
    let [nu12, nu13, nu23] = c.poisson_ratios;
    let [G12, G13, G23] = c.shear_moduli;
    let swapped = EngineeringConstants {
        youngs_moduli: [E2, E1, E3],
        poisson_ratios: [nu12 * E2 / E1, nu23, nu13],
        shear_moduli: [G12, G23, G13],
    };
    assert!(distance(&rotated, &swapped.material_elasticity()) < 1e-13);
}

#[test]
fn isotropy_survives_any_rotation_and_transverse_isotropy_any_turn_about_its_axis() {
    // 1e-13 relative: round-off of two 6×6 products.
    let isotropic = EngineeringConstants::isotropic(7.0e10, 0.33).material_elasticity();
    let lining_constants =
        EngineeringConstants::transversely_isotropic((8.0e9, 0.2), 2.5e9, 0.1, 1.2e9);
    let transverse = lining_constants.material_elasticity();
    for (a, b, c) in [(0.3, 1.1, -0.7), (2.0, -0.4, 0.9), (-1.3, 2.2, 0.1)] {
        let any = rotation(a, b, c);
        assert!(distance(&to_global(&isotropic, &any), &isotropic) < 1e-13);
        let about_3 = rotation(a, 0.0, 0.0);
        assert!(distance(&to_global(&transverse, &about_3), &transverse) < 1e-13);
    }
    // So the `normal` frame's completion does not matter: the pad normal along z gives the
    // global-frame constants whatever axis 1 it picks.
    let frame = Frame::Normal {
        axis3: [0.0, 0.0, -2.0],
    };
    frame.check("lining", &lining_constants).unwrap();
    let axes = frame.axes_at([0.0; 3]).unwrap();
    assert!(distance(&to_global(&transverse, &axes), &transverse) < 1e-13);
}

#[test]
fn the_frames_give_right_handed_axes_where_the_doc_puts_them() {
    let cylindrical = Frame::Cylindrical {
        origin: [1.0, 1.0, 0.0],
        axis: [0.0, 0.0, 2.0],
    };
    let axes = cylindrical.axes_at([1.0, 3.0, 5.0]).unwrap();
    let expected = [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
    for (row, want) in axes.iter().zip(expected) {
        for (value, want) in row.iter().zip(want) {
            assert!((value - want).abs() < 1e-15, "{axes:?}");
        }
    }
    let err = cylindrical.axes_at([1.0, 1.0, 4.0]).unwrap_err();
    assert!(err.message.contains("on its axis"), "{err}");
    for frame in [
        Frame::Normal {
            axis3: [0.3, -0.5, 0.8],
        },
        Frame::Axes {
            axis1: [1.0, 2.0, 0.5],
            axis3: [0.3, -0.5, 0.8],
        },
    ] {
        let [e1, e2, e3] = frame.axes_at([0.0; 3]).unwrap();
        for (a, b, expected) in [
            (e1, e1, 1.0),
            (e2, e2, 1.0),
            (e3, e3, 1.0),
            (e1, e2, 0.0),
            (e1, e3, 0.0),
        ] {
            assert!((dot(a, b) - expected).abs() < 1e-15);
        }
        let handed = cross(e1, e2);
        assert!(
            (dot(handed, e3) - 1.0).abs() < 1e-15,
            "left-handed {frame:?}"
        );
    }
}

#[test]
fn constants_that_are_no_material_are_refused_with_what_is_wrong() {
    let message = |c: EngineeringConstants| c.check("lining").unwrap_err().message;
    // ν = 0.6 isotropic: 1 − 3ν² − 2ν³ < 0.
    let m = message(EngineeringConstants::isotropic(1.0e9, 0.6));
    assert!(
        m.contains("material `lining`") && m.contains("not a material"),
        "{m}"
    );
    // |ν_12| beyond √(E_1/E_2).
    let mut c = lining();
    c.poisson_ratios[0] = 1.2;
    assert!(message(c).contains("not a material"));
    let mut c = lining();
    c.shear_moduli[1] = 0.0;
    assert!(message(c).contains("moduli must be positive"));
    lining().check("lining").unwrap();
    // A normal alone cannot orient constants that differ within the plane.
    let err = Frame::Normal {
        axis3: [0.0, 0.0, 1.0],
    }
    .check("lining", &lining())
    .unwrap_err();
    assert!(err.message.contains("give axis 1 too"), "{err}");
    let err = Frame::Axes {
        axis1: [0.0, 0.0, 2.0],
        axis3: [0.0, 0.0, 1.0],
    }
    .check("lining", &lining())
    .unwrap_err();
    assert!(err.message.contains("parallel"), "{err}");
}

#[test]
fn isotropic_elasticity_gives_the_uniaxial_stress_modulus() {
    // Uniaxial stress: ε = (1, −ν, −ν, 0, 0, 0) gives σ = (E, 0, 0, 0, 0, 0), to rounding.
    let D = isotropic_elasticity(2.0e11, 0.3);
    let strain = [1.0, -0.3, -0.3, 0.0, 0.0, 0.0];
    let stress: Vec<f64> = (0..6)
        .map(|row| (0..6).map(|col| D[row][col] * strain[col]).sum())
        .collect();
    assert!((stress[0] - 2.0e11).abs() < 1e-4);
    assert!(stress[1].abs() < 1e-4 && stress[2].abs() < 1e-4);
}

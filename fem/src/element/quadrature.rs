//! Quadrature rules on the reference elements, each exact for the stiffness and the consistent
//! mass of a straight-sided element of its kind.
//!
//! With `p` the polynomial degree of the shape functions in a reference coordinate, the mass
//! integrand `N_a N_b` has degree `2p` and, for an affine map, the stiffness integrand
//! `∇N_a · D ∇N_b` degree `2p − 2`:
//!
//! | kind | mass degree | rule | exact to |
//! |---|---|---|---|
//! | `tet4` | 2 | 4 points, symmetric | 2 |
//! | `tet10` | 4 | 14 points, symmetric, positive weights (Walkington) | 5 |
//! | `wedge6` | 2 (triangle) × 2 (ζ) | 3-point triangle × 2-point Gauss | 2 × 3 |
//! | `wedge15` | 4 × 4 | 6-point triangle (Dunavant) × 3-point Gauss | 4 × 5 |
//! | `hex8` | 2 per coordinate | 2×2×2 Gauss | 3 per coordinate |
//! | `hex20` | 4 per coordinate | 3×3×3 Gauss | 5 per coordinate |
//!
//! The 2×2×2 rule under-integrates the 20-node hexahedron's stiffness (hourglass modes): it is
//! not used for it. Reference volumes: tetrahedron 1/6, wedge 1 (triangle 1/2 × 2), cube 8.

use std::sync::LazyLock;

use crate::artifact::ElementKind;

/// A point of a rule: reference coordinates and weight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    pub xi: [f64; 3],
    pub weight: f64,
}

/// The rule of each kind's stiffness and mass.
pub fn rule(kind: ElementKind) -> &'static [Point] {
    match kind {
        ElementKind::Tet4 => &TET_DEGREE_2,
        ElementKind::Tet10 => &TET_DEGREE_5,
        ElementKind::Wedge6 => &WEDGE_6,
        ElementKind::Wedge15 => &WEDGE_15,
        ElementKind::Hex8 => &GAUSS_2X2X2,
        ElementKind::Hex20 => &GAUSS_3X3X3,
    }
}

/// Gauss–Legendre points and weights on [−1, 1].
pub const GAUSS_2: [(f64, f64); 2] = [
    (-0.577_350_269_189_625_8, 1.0),
    (0.577_350_269_189_625_8, 1.0),
];
pub const GAUSS_3: [(f64, f64); 3] = [
    (-0.774_596_669_241_483_4, 5.0 / 9.0),
    (0.0, 8.0 / 9.0),
    (0.774_596_669_241_483_4, 5.0 / 9.0),
];

/// The points with the same barycentric coordinates up to permutation: `(a, a, …, rest)` over
/// `n` barycentric coordinates. Returns the distinct permutations of `values`.
fn permutations(values: &[f64]) -> Vec<Vec<f64>> {
    fn go(rest: &mut Vec<f64>, prefix: &mut Vec<f64>, out: &mut Vec<Vec<f64>>) {
        if rest.is_empty() {
            if !out.contains(prefix) {
                out.push(prefix.clone());
            }
            return;
        }
        for idx in 0..rest.len() {
            let value = rest.remove(idx);
            prefix.push(value);
            go(rest, prefix, out);
            prefix.pop();
            rest.insert(idx, value);
        }
    }
    let mut out = Vec::new();
    go(&mut values.to_vec(), &mut Vec::new(), &mut out);
    out
}

/// A symmetric tetrahedral rule from orbits `(barycentric coordinates, weight per point)`: the
/// reference coordinates are the last three barycentric ones.
fn tetrahedral(orbits: &[([f64; 4], f64)]) -> Vec<Point> {
    orbits
        .iter()
        .flat_map(|(barycentric, weight)| {
            permutations(barycentric).into_iter().map(|l| Point {
                xi: [l[1], l[2], l[3]],
                weight: *weight,
            })
        })
        .collect()
}

/// A symmetric triangle rule (reference coordinates `(r, s)`, area 1/2).
fn triangular(orbits: &[([f64; 3], f64)]) -> Vec<([f64; 2], f64)> {
    orbits
        .iter()
        .flat_map(|(barycentric, weight)| {
            permutations(barycentric)
                .into_iter()
                .map(|l| ([l[1], l[2]], *weight))
        })
        .collect()
}

fn prism(triangle: &[([f64; 2], f64)], line: &[(f64, f64)]) -> Vec<Point> {
    line.iter()
        .flat_map(|&(zeta, line_weight)| {
            triangle.iter().map(move |&([r, s], weight)| Point {
                xi: [r, s, zeta],
                weight: weight * line_weight,
            })
        })
        .collect()
}

fn cube(line: &[(f64, f64)]) -> Vec<Point> {
    let mut points = Vec::with_capacity(line.len().pow(3));
    for &(zeta, wz) in line {
        for &(eta, wy) in line {
            for &(xi, wx) in line {
                points.push(Point {
                    xi: [xi, eta, zeta],
                    weight: wx * wy * wz,
                });
            }
        }
    }
    points
}

static TET_DEGREE_2: LazyLock<Vec<Point>> = LazyLock::new(|| {
    let (a, b) = (0.138_196_601_125_010_5, 0.585_410_196_624_968_5);
    tetrahedral(&[([a, a, a, b], 1.0 / 24.0)])
});

/// Walkington's 14-point rule of degree 5 (all weights positive).
static TET_DEGREE_5: LazyLock<Vec<Point>> = LazyLock::new(|| {
    let a1 = 0.092_735_250_310_891_23;
    let a2 = 0.310_885_919_263_300_6;
    let b = 0.454_496_295_874_350_38;
    tetrahedral(&[
        ([a1, a1, a1, 1.0 - 3.0 * a1], 0.012_248_840_519_393_66),
        ([a2, a2, a2, 1.0 - 3.0 * a2], 0.018_781_320_953_002_645),
        ([b, b, 0.5 - b, 0.5 - b], 0.007_091_003_462_846_908),
    ])
});

static WEDGE_6: LazyLock<Vec<Point>> = LazyLock::new(|| {
    let triangle = triangular(&[([2.0 / 3.0, 1.0 / 6.0, 1.0 / 6.0], 1.0 / 6.0)]);
    prism(&triangle, &GAUSS_2)
});

/// Dunavant's 6-point triangle rule of degree 4 (reference coordinates `(r, s)`, area 1/2):
/// for the 15-node wedge and for faces.
pub static TRIANGLE_DEGREE_4: LazyLock<Vec<([f64; 2], f64)>> = LazyLock::new(|| {
    let (a, b) = (0.445_948_490_915_964_9, 0.091_576_213_509_770_74);
    triangular(&[
        ([a, a, 1.0 - 2.0 * a], 0.111_690_794_839_005_73),
        ([b, b, 1.0 - 2.0 * b], 0.054_975_871_827_660_934),
    ])
});

/// Radon's 7-point triangle rule of degree 5 (reference coordinates `(r, s)`, area 1/2): the
/// centroid and two orbits at a = (6 ∓ √15)/21, weights (155 ∓ √15)/2400. For mortar segments.
pub static TRIANGLE_DEGREE_5: LazyLock<Vec<([f64; 2], f64)>> = LazyLock::new(|| {
    let root = 15f64.sqrt();
    let (a, b) = ((6.0 - root) / 21.0, (6.0 + root) / 21.0);
    triangular(&[
        ([1.0 / 3.0; 3], 9.0 / 80.0),
        ([a, a, 1.0 - 2.0 * a], (155.0 - root) / 2400.0),
        ([b, b, 1.0 - 2.0 * b], (155.0 + root) / 2400.0),
    ])
});

/// The 6-point triangle rule × 3-point Gauss.
static WEDGE_15: LazyLock<Vec<Point>> = LazyLock::new(|| prism(&TRIANGLE_DEGREE_4, &GAUSS_3));

static GAUSS_2X2X2: LazyLock<Vec<Point>> = LazyLock::new(|| cube(&GAUSS_2));
static GAUSS_3X3X3: LazyLock<Vec<Point>> = LazyLock::new(|| cube(&GAUSS_3));

#[cfg(test)]
mod tests {
    use super::*;

    fn factorial(n: u32) -> f64 {
        (1..=n).map(f64::from).product()
    }

    /// ∫ x^i y^j z^k over the reference element, exactly.
    fn moment(kind: ElementKind, [i, j, k]: [u32; 3]) -> f64 {
        match kind {
            ElementKind::Tet4 | ElementKind::Tet10 => {
                factorial(i) * factorial(j) * factorial(k) / factorial(i + j + k + 3)
            }
            ElementKind::Wedge6 | ElementKind::Wedge15 => {
                let triangle = factorial(i) * factorial(j) / factorial(i + j + 2);
                let line = if k % 2 == 0 {
                    2.0 / f64::from(k + 1)
                } else {
                    0.0
                };
                triangle * line
            }
            ElementKind::Hex8 | ElementKind::Hex20 => [i, j, k]
                .iter()
                .map(|&p| {
                    if p % 2 == 0 {
                        2.0 / f64::from(p + 1)
                    } else {
                        0.0
                    }
                })
                .product(),
        }
    }

    /// The exponents a rule must integrate exactly: total degree for simplices, per coordinate
    /// (triangle total degree, ζ degree) for wedges, per coordinate for cubes.
    fn exact_exponents(kind: ElementKind) -> Vec<[u32; 3]> {
        let mut all = Vec::new();
        for i in 0..=5 {
            for j in 0..=5 {
                for k in 0..=5 {
                    let exact = match kind {
                        ElementKind::Tet4 => i + j + k <= 2,
                        ElementKind::Tet10 => i + j + k <= 5,
                        ElementKind::Wedge6 => i + j <= 2 && k <= 3,
                        ElementKind::Wedge15 => i + j <= 4 && k <= 5,
                        ElementKind::Hex8 => i <= 3 && j <= 3 && k <= 3,
                        ElementKind::Hex20 => true,
                    };
                    if exact {
                        all.push([i, j, k]);
                    }
                }
            }
        }
        all
    }

    #[test]
    fn every_rule_integrates_its_monomials_exactly() {
        for kind in ElementKind::ALL {
            for exponents in exact_exponents(kind) {
                let quadrature: f64 = rule(kind)
                    .iter()
                    .map(|p| {
                        p.weight
                            * (0..3)
                                .map(|d| p.xi[d].powi(exponents[d] as i32))
                                .product::<f64>()
                    })
                    .sum();
                let exact = moment(kind, exponents);
                assert!(
                    (quadrature - exact).abs() < 1e-15 * exact.abs().max(1.0),
                    "{kind} x^{exponents:?}: {quadrature} != {exact}"
                );
            }
        }
    }

    #[test]
    fn the_triangle_rules_integrate_their_degrees_exactly() {
        for (rule, degree, size) in [(&*TRIANGLE_DEGREE_4, 4, 6), (&*TRIANGLE_DEGREE_5, 5, 7)] {
            assert_eq!(rule.len(), size);
            assert!(rule.iter().all(|&(_, weight)| weight > 0.0));
            for i in 0..=degree {
                for j in 0..=degree - i {
                    let quadrature: f64 = rule
                        .iter()
                        .map(|&([r, s], weight)| weight * r.powi(i as i32) * s.powi(j as i32))
                        .sum();
                    let exact = factorial(i) * factorial(j) / factorial(i + j + 2);
                    assert!(
                        (quadrature - exact).abs() < 1e-16,
                        "degree {degree}: r^{i} s^{j}: {quadrature} != {exact}"
                    );
                }
            }
        }
    }

    #[test]
    fn rules_have_the_documented_sizes_and_positive_weights() {
        let sizes = [
            (ElementKind::Tet4, 4),
            (ElementKind::Tet10, 14),
            (ElementKind::Wedge6, 6),
            (ElementKind::Wedge15, 18),
            (ElementKind::Hex8, 8),
            (ElementKind::Hex20, 27),
        ];
        for (kind, size) in sizes {
            assert_eq!(rule(kind).len(), size, "{kind}");
            assert!(rule(kind).iter().all(|p| p.weight > 0.0), "{kind}");
        }
    }
}

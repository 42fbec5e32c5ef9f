//! Verification of every element kind on single elements: shape functions (partition of
//! unity, interpolation, gradients against finite differences, the polynomials each kind
//! reproduces), rigid motions, constant-strain energy, exact volume and mass under an affine
//! map, and refusal of inverted elements. Patch tests on distorted meshes of each kind and
//! convergence against analytic solutions are in `squeal_model::assemble` tests.

use super::topology::{self, reference_node};
use super::*;

const ALL: [ElementKind; 6] = ElementKind::ALL;

fn steel() -> [[f64; 6]; 6] {
    crate::artifact::material::isotropic_elasticity(2.0e11, 0.3)
}

fn shapes_at(kind: ElementKind, xi: [f64; 3]) -> (Vec<f64>, Vec<[f64; 3]>) {
    let n = kind.n_nodes();
    let (mut values, mut gradients) = (vec![0.0; n], vec![[0.0; 3]; n]);
    shapes::evaluate(kind, xi, &mut values, &mut gradients);
    (values, gradients)
}

/// Points inside each reference element (away from its nodes).
fn interior_points(kind: ElementKind) -> Vec<[f64; 3]> {
    match kind {
        ElementKind::Tet4 | ElementKind::Tet10 => {
            vec![[0.1, 0.2, 0.3], [0.25, 0.25, 0.25], [0.6, 0.1, 0.05]]
        }
        ElementKind::Wedge6 | ElementKind::Wedge15 => {
            vec![[0.1, 0.2, -0.7], [0.3, 0.3, 0.0], [0.6, 0.1, 0.45]]
        }
        ElementKind::Hex8 | ElementKind::Hex20 => {
            vec![[-0.7, 0.2, 0.4], [0.0, 0.0, 0.0], [0.5, -0.9, -0.3]]
        }
    }
}

/// An affine map x = A ξ + b with det A > 0, and its determinant.
fn affine() -> ([[f64; 3]; 3], [f64; 3], f64) {
    let A = [
        [0.03, 0.004, -0.002],
        [0.001, 0.02, 0.003],
        [-0.002, 0.005, 0.025],
    ];
    let det = A[0][0] * (A[1][1] * A[2][2] - A[1][2] * A[2][1])
        - A[0][1] * (A[1][0] * A[2][2] - A[1][2] * A[2][0])
        + A[0][2] * (A[1][0] * A[2][1] - A[1][1] * A[2][0]);
    (A, [0.1, -0.2, 0.05], det)
}

fn mapped(kind: ElementKind, map: &dyn Fn([f64; 3]) -> [f64; 3]) -> Vec<[f64; 3]> {
    (0..kind.n_nodes())
        .map(|node| map(reference_node(kind, node)))
        .collect()
}

fn affine_coords(kind: ElementKind) -> Vec<[f64; 3]> {
    let (A, b, _) = affine();
    mapped(kind, &|xi| {
        std::array::from_fn(|i| (0..3).map(|j| A[i][j] * xi[j]).sum::<f64>() + b[i])
    })
}

/// A distorted element: the affine map plus a smooth non-linear term, with mid-edge nodes
/// moved back to the middle of their (now distorted) edge so that edges stay straight.
fn distorted_coords(kind: ElementKind) -> Vec<[f64; 3]> {
    let (A, b, _) = affine();
    let map = |xi: [f64; 3]| -> [f64; 3] {
        let warp = 0.004 * xi[0] * xi[1] + 0.003 * xi[1] * xi[2] - 0.002 * xi[0] * xi[2];
        std::array::from_fn(|i| {
            (0..3).map(|j| A[i][j] * xi[j]).sum::<f64>() + b[i] + if i == 2 { warp } else { 0.0 }
        })
    };
    let mut coords = mapped(kind, &map);
    for (k, &[a, b]) in topology::edges(kind).iter().enumerate() {
        let node = kind.n_corners() + k;
        if node < kind.n_nodes() {
            coords[node] = std::array::from_fn(|i| 0.5 * (coords[a][i] + coords[b][i]));
        }
    }
    coords
}

fn stiffness_times(matrices: &ElementMatrices, u: &[f64]) -> Vec<f64> {
    (0..u.len())
        .map(|i| {
            (0..u.len())
                .map(|j| matrices.stiffness[packed_index(i, j)] * u[j])
                .sum()
        })
        .collect()
}

#[test]
fn shape_functions_interpolate_their_nodes_and_sum_to_one() {
    for kind in ALL {
        for node in 0..kind.n_nodes() {
            let (values, _) = shapes_at(kind, reference_node(kind, node));
            for (other, value) in values.iter().enumerate() {
                let expected = if other == node { 1.0 } else { 0.0 };
                assert!(
                    (value - expected).abs() < 1e-14,
                    "{kind} N_{other}(x_{node}) = {value}"
                );
            }
        }
        for xi in interior_points(kind) {
            let (values, gradients) = shapes_at(kind, xi);
            assert!((values.iter().sum::<f64>() - 1.0).abs() < 1e-14, "{kind}");
            for i in 0..3 {
                let sum: f64 = gradients.iter().map(|g| g[i]).sum();
                assert!(sum.abs() < 1e-13, "{kind}: Σ ∂N/∂ξ_{i} = {sum}");
            }
        }
    }
}

#[test]
fn gradients_match_finite_differences() {
    let h = 1e-6;
    for kind in ALL {
        for xi in interior_points(kind) {
            let (_, gradients) = shapes_at(kind, xi);
            for i in 0..3 {
                let mut plus = xi;
                let mut minus = xi;
                plus[i] += h;
                minus[i] -= h;
                let (up, _) = shapes_at(kind, plus);
                let (down, _) = shapes_at(kind, minus);
                for a in 0..kind.n_nodes() {
                    let difference = (up[a] - down[a]) / (2.0 * h);
                    assert!(
                        (difference - gradients[a][i]).abs() < 1e-8,
                        "{kind} ∂N_{a}/∂ξ_{i}: {} vs {difference}",
                        gradients[a][i]
                    );
                }
            }
        }
    }
}

#[test]
fn each_kind_reproduces_the_polynomials_of_its_order() {
    // Every kind reproduces linear fields; the second-order ones complete quadratics.
    let linear = |x: [f64; 3]| 0.3 + 1.2 * x[0] - 0.7 * x[1] + 2.1 * x[2];
    let quadratic = |x: [f64; 3]| {
        linear(x) + 0.4 * x[0] * x[0] - 0.9 * x[1] * x[2] + 0.6 * x[2] * x[2] + 0.2 * x[0] * x[1]
    };
    for kind in ALL {
        let fields: Vec<&dyn Fn([f64; 3]) -> f64> = if topology::is_quadratic(kind) {
            vec![&linear, &quadratic]
        } else {
            vec![&linear]
        };
        for field in fields {
            for xi in interior_points(kind) {
                let (values, _) = shapes_at(kind, xi);
                let interpolated: f64 = (0..kind.n_nodes())
                    .map(|a| values[a] * field(reference_node(kind, a)))
                    .sum();
                assert!((interpolated - field(xi)).abs() < 1e-13, "{kind} at {xi:?}");
            }
        }
    }
}

#[test]
fn rigid_motions_cost_no_energy() {
    for kind in ALL {
        let coords = distorted_coords(kind);
        let matrices = element_matrices(kind, &coords, &steel(), 7850.0).unwrap();
        let n_dofs = 3 * kind.n_nodes();
        let scale = (0..n_dofs)
            .map(|i| matrices.stiffness[packed_index(i, i)].abs())
            .fold(0.0, f64::max);
        let rotation: Vec<f64> = (0..n_dofs)
            .map(|dof| {
                let x = coords[dof / 3];
                // θ × x with θ = (0.2, −0.5, 1).
                match dof % 3 {
                    0 => -0.5 * x[2] - x[1],
                    1 => x[0] - 0.2 * x[2],
                    _ => 0.2 * x[1] + 0.5 * x[0],
                }
            })
            .collect();
        let translation: Vec<f64> = (0..n_dofs).map(|dof| [0.3, -1.0, 0.7][dof % 3]).collect();
        for motion in [rotation, translation] {
            let force = stiffness_times(&matrices, &motion);
            let largest = force.iter().fold(0.0f64, |m, f| m.max(f.abs()));
            assert!(largest < 1e-9 * scale, "{kind}: |K u_rigid| = {largest:e}");
        }
    }
}

#[test]
fn a_constant_strain_stores_its_exact_energy() {
    // u = E x with a symmetric E: ε is constant and uᵀ K u = εᵀ D ε V, on distorted
    // straight-edged elements (the patch test's energy form).
    let E = [
        [1e-3, 2e-4, -1e-4],
        [2e-4, -5e-4, 3e-4],
        [-1e-4, 3e-4, 4e-4],
    ];
    let strain = [
        E[0][0],
        E[1][1],
        E[2][2],
        2.0 * E[0][1],
        2.0 * E[1][2],
        2.0 * E[2][0],
    ];
    let D = steel();
    let density: f64 = (0..6)
        .map(|i| (0..6).map(|j| strain[i] * D[i][j] * strain[j]).sum::<f64>())
        .sum();
    for kind in ALL {
        let coords = distorted_coords(kind);
        let matrices = element_matrices(kind, &coords, &D, 1.0).unwrap();
        let u: Vec<f64> = (0..3 * kind.n_nodes())
            .map(|dof| (0..3).map(|j| E[dof % 3][j] * coords[dof / 3][j]).sum())
            .collect();
        let energy: f64 = u
            .iter()
            .zip(stiffness_times(&matrices, &u))
            .map(|(u, f)| u * f)
            .sum();
        let exact = density * matrices.volume;
        assert!(
            (energy - exact).abs() < 1e-12 * exact,
            "{kind}: {energy} vs {exact}"
        );
    }
}

#[test]
fn volume_and_mass_are_exact_under_an_affine_map() {
    let (_, _, det) = affine();
    for kind in ALL {
        let reference_volume = match kind {
            ElementKind::Tet4 | ElementKind::Tet10 => 1.0 / 6.0,
            ElementKind::Wedge6 | ElementKind::Wedge15 => 1.0,
            ElementKind::Hex8 | ElementKind::Hex20 => 8.0,
        };
        let matrices = element_matrices(kind, &affine_coords(kind), &steel(), 2.5).unwrap();
        let volume = reference_volume * det;
        assert!((matrices.volume - volume).abs() < 1e-14 * volume, "{kind}");
        let n = kind.n_nodes();
        let total: f64 = (0..n)
            .flat_map(|a| (0..n).map(move |b| (a, b)))
            .map(|(a, b)| matrices.mass[packed_index(a, b)])
            .sum();
        assert!((total - 2.5 * volume).abs() < 1e-13 * total, "{kind}");
    }
}

#[test]
fn the_consistent_mass_of_a_tetrahedron_is_the_textbook_one() {
    // Linear tetrahedron: M_ab = ρ V (1 + δ_ab) / 20.
    let coords = affine_coords(ElementKind::Tet4);
    let matrices = element_matrices(ElementKind::Tet4, &coords, &steel(), 3.0).unwrap();
    for a in 0..4 {
        for b in 0..4 {
            let expected = 3.0 * matrices.volume * if a == b { 2.0 } else { 1.0 } / 20.0;
            let got = matrices.mass[packed_index(a, b)];
            assert!((got - expected).abs() < 1e-14 * expected, "M_{a}{b}");
        }
    }
    // Quadratic tetrahedron, in units of ρV/420: corner 6, corner–corner 1, corner–mid −4 on
    // the corner's edges and −6 off them, mid 32, mid–mid 16 for edges sharing a corner and 8
    // for opposite edges.
    let coords = affine_coords(ElementKind::Tet10);
    let matrices = element_matrices(ElementKind::Tet10, &coords, &steel(), 3.0).unwrap();
    let unit = 3.0 * matrices.volume / 420.0;
    let edges = topology::edges(ElementKind::Tet10);
    for a in 0..10 {
        for b in 0..10 {
            let expected = match (a < 4, b < 4) {
                (true, true) => {
                    if a == b {
                        6.0
                    } else {
                        1.0
                    }
                }
                (false, false) => {
                    let (ea, eb) = (edges[a - 4], edges[b - 4]);
                    if a == b {
                        32.0
                    } else if ea.iter().any(|corner| eb.contains(corner)) {
                        16.0
                    } else {
                        8.0
                    }
                }
                (true, false) | (false, true) => {
                    let (corner, mid) = if a < 4 { (a, b) } else { (b, a) };
                    if edges[mid - 4].contains(&corner) {
                        -4.0
                    } else {
                        -6.0
                    }
                }
            } * unit;
            let got = matrices.mass[packed_index(a, b)];
            assert!(
                (got - expected).abs() < 1e-13 * 32.0 * unit,
                "M_{a}{b}: {got} vs {expected}"
            );
        }
    }
}

#[test]
fn inverted_elements_are_refused_with_where() {
    for kind in ALL {
        let mut coords = distorted_coords(kind);
        // Mirror the element: every det J changes sign.
        for x in &mut coords {
            x[2] = -x[2];
        }
        let inverted = first_inverted(kind, &coords).expect("a mirrored element is inverted");
        assert!(inverted.det_j < 0.0, "{kind}");
        let err = element_matrices(kind, &coords, &steel(), 1.0).unwrap_err();
        assert!(err.det_j <= 0.0, "{kind}");
        assert!(
            first_inverted(kind, &distorted_coords(kind)).is_none(),
            "{kind}"
        );
    }
}

#[test]
fn faces_are_outward_on_tetrahedra_and_wedges_and_cover_each_kind() {
    // The right-hand normal of each face of the reference element points away from its centre.
    for kind in [
        ElementKind::Tet4,
        ElementKind::Tet10,
        ElementKind::Wedge6,
        ElementKind::Wedge15,
    ] {
        let centre = topology::reference_centre(kind);
        for face in 0..topology::n_faces(kind) {
            let nodes = topology::face_nodes(kind, face);
            assert_eq!(nodes.len(), topology::face_kind(kind, face).n_nodes());
            let p: Vec<[f64; 3]> = nodes.iter().map(|&a| reference_node(kind, a)).collect();
            let normal = crate::artifact::mesh::cross(
                crate::artifact::mesh::sub(p[1], p[0]),
                crate::artifact::mesh::sub(p[2], p[0]),
            );
            let outward = crate::artifact::mesh::sub(p[0], centre);
            assert!(
                crate::artifact::mesh::dot(normal, outward) > 0.0,
                "{kind} face {face}"
            );
        }
    }
    // Every node of every kind is on some face.
    for kind in ALL {
        let mut on_face = vec![false; kind.n_nodes()];
        for face in 0..topology::n_faces(kind) {
            for node in topology::face_nodes(kind, face) {
                on_face[node] = true;
            }
        }
        assert!(on_face.iter().all(|&on| on), "{kind}");
    }
}

#[test]
fn every_format_order_is_a_permutation_that_round_trips() {
    use formats::{Format, file_to_squeal, from_file, to_file};
    for kind in ALL {
        for format in [Format::Gmsh, Format::Abaqus, Format::Nastran, Format::Vtk] {
            let mut order = file_to_squeal(kind, format);
            let file: Vec<u32> = (100..100 + kind.n_nodes() as u32).collect();
            assert_eq!(to_file(kind, format, &from_file(kind, format, &file)), file);
            order.sort_unstable();
            assert_eq!(
                order,
                (0..kind.n_nodes()).collect::<Vec<_>>(),
                "{kind} {format:?}"
            );
        }
    }
    // Gmsh's 10-node tetrahedron swaps the last two nodes.
    assert_eq!(
        file_to_squeal(ElementKind::Tet10, Format::Gmsh),
        [0, 1, 2, 3, 4, 5, 6, 7, 9, 8]
    );
}

//! The constant-strain patch test of every element kind on a distorted mesh: the
//! incompatible-mode hexahedron, and the tetrahedra, wedges and 20-node hexahedra made from the
//! same distorted cube (split, with mid-edge nodes at the middle of the distorted edges).

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use serde::Deserialize;
use squeal_stages::artifact::{ElementKind, Mesh};
use squeal_stages::assemble::with_default_materials;
use squeal_stages::fem::element::{self, hex8};
use squeal_stages::mesh::{convert, structured};

use crate::reference;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Patch {
    /// Largest shift of an interior node, in each direction (m, on a unit cube of 3 × 3 × 3).
    distortion_m: f64,
    /// The imposed linear field u = offset + gradient · x.
    gradient: [[f64; 3]; 3],
    offset: [f64; 3],
    /// Error of the interior displacements, relative to the largest boundary displacement.
    displacement_tolerance: f64,
    /// Error of each Gauss point's stress, relative to the largest stress component.
    stress_tolerance: f64,
}

/// The distorted cube of 3×3×3 hexahedra as elements of `kind`.
fn distorted_cube(case: &Patch, kind: ElementKind) -> Mesh {
    let mut mesh = structured::block([1.0, 1.0, 1.0], [3, 3, 3], "disc");
    let boundary: std::collections::BTreeSet<u32> = ["x0", "x1", "y0", "y1", "z0", "z1"]
        .iter()
        .flat_map(|face| mesh.node_sets[*face].iter().copied())
        .collect();
    let interior: Vec<usize> = (0..mesh.n_nodes())
        .filter(|node| !boundary.contains(&(*node as u32)))
        .collect();
    assert_eq!(interior.len(), 8);
    for (count, &node) in interior.iter().enumerate() {
        let shift = |k: usize| case.distortion_m * (((count * 7 + k * 3) % 5) as f64 / 2.0 - 1.0);
        for direction in 0..3 {
            mesh.nodes[node][direction] += shift(direction);
        }
    }
    convert::as_kind(&mesh, kind)
}

/// Moves the interior nodes of a 3×3×3 block, imposes a linear displacement on the boundary,
/// solves for the interior: the solution must be the linear field, the strain constant.
#[test]
fn constant_strain_patch_test_on_a_distorted_mesh() {
    let case: Patch = reference::load("patch_test");
    for kind in ElementKind::ALL {
        patch_test(&case, kind);
    }
}

fn patch_test(case: &Patch, kind: ElementKind) {
    let mesh = distorted_cube(case, kind);
    assert!(mesh.elements.iter().all(|element| element.kind == kind));
    let boundary: std::collections::BTreeSet<u32> = ["x0", "x1", "y0", "y1", "z0", "z1"]
        .iter()
        .flat_map(|face| mesh.node_sets[*face].iter().copied())
        .collect();
    let interior: Vec<usize> = (0..mesh.n_nodes())
        .filter(|node| !boundary.contains(&(*node as u32)))
        .collect();
    let (gradient, offset) = (case.gradient, case.offset);
    let exact = |x: [f64; 3]| -> [f64; 3] {
        std::array::from_fn(|i| offset[i] + (0..3).map(|j| gradient[i][j] * x[j]).sum::<f64>())
    };
    let (model, params) = with_default_materials(&mesh, "", &[]).expect("assembly");
    let K = model.K.to_dense();
    let interior_dofs: Vec<usize> = interior
        .iter()
        .flat_map(|&node| (0..3).map(move |d| 3 * node + d))
        .collect();
    let mut prescribed = vec![0.0; model.n_dofs()];
    for &node in &boundary {
        let value = exact(mesh.nodes[node as usize]);
        for d in 0..3 {
            prescribed[3 * node as usize + d] = value[d];
        }
    }
    let n_interior = interior_dofs.len();
    let K_interior = Mat::from_fn(n_interior, n_interior, |i, j| {
        K[(interior_dofs[i], interior_dofs[j])]
    });
    let rhs = Mat::from_fn(n_interior, 1, |i, _| {
        -(0..model.n_dofs())
            .map(|j| K[(interior_dofs[i], j)] * prescribed[j])
            .sum::<f64>()
    });
    let solution = K_interior
        .llt(Side::Lower)
        .expect("K is positive definite on the interior")
        .solve(&rhs);
    let mut displacement = prescribed.clone();
    for (i, &dof) in interior_dofs.iter().enumerate() {
        displacement[dof] = solution[(i, 0)];
    }
    let scale = prescribed.iter().fold(0.0f64, |m, u| m.max(u.abs()));
    for &node in &interior {
        let want = exact(mesh.nodes[node]);
        for d in 0..3 {
            let error = (displacement[3 * node + d] - want[d]).abs();
            assert!(
                error <= case.displacement_tolerance * scale,
                "{kind} node {node} dir {d}: error {error:e}"
            );
        }
    }
    // Constant strain ε = sym(∇u) (engineering shears), hence constant stress σ = D ε.
    let expected_strain = element::engineering_strain(&gradient);
    let D = params
        .material("disc")
        .expect("default material")
        .elasticity_at([0.0; 3])
        .expect("an isotropic material");
    let stress = |strain: &[f64; 6]| -> [f64; 6] {
        std::array::from_fn(|i| (0..6).map(|j| D[i][j] * strain[j]).sum())
    };
    let expected_stress = stress(&expected_strain);
    let stress_scale = expected_stress.iter().fold(0.0f64, |m, s| m.max(s.abs()));
    for element in mesh.elements.iter() {
        let coords: Vec<[f64; 3]> = element
            .nodes
            .iter()
            .map(|&node| mesh.nodes[node as usize])
            .collect();
        let strains: Vec<[f64; 6]> = if kind == ElementKind::Hex8 {
            // Every Gauss point, incompatible modes included.
            let coords: [[f64; 3]; 8] = coords.try_into().expect("8 nodes");
            let element_displacement: [f64; 24] = std::array::from_fn(|dof| {
                displacement[3 * element.nodes[dof / 3] as usize + dof % 3]
            });
            hex8::gauss_point_strains(&coords, &D, &element_displacement)
                .expect("no element is inverted")
                .to_vec()
        } else {
            // The displacement is the linear field at every node, hence everywhere: the
            // strain at the centre stands for all points.
            let nodal: Vec<[f64; 3]> = element
                .nodes
                .iter()
                .map(|&node| std::array::from_fn(|d| displacement[3 * node as usize + d]))
                .collect();
            let g = element::centre_displacement_gradient(kind, &coords, &nodal)
                .expect("no element is inverted");
            vec![element::engineering_strain(&g)]
        };
        for strain in strains {
            let got = stress(&strain);
            for s in 0..6 {
                assert!(
                    (got[s] - expected_stress[s]).abs() <= case.stress_tolerance * stress_scale,
                    "{kind} stress {s}: {} vs {}",
                    got[s],
                    expected_stress[s]
                );
            }
        }
    }
}

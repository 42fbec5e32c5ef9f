//! The displacement element of any kind but `hex8`: isoparametric, `x(ξ) = Σ_a N_a(ξ) x_a`,
//! `u(ξ) = Σ_a N_a(ξ) u_a`, with the kind's rule `(ξ_g, w_g)`:
//!
//! ```text
//! J_ij = ∂x_j/∂ξ_i,   ∇ₓ N_a = J⁻¹ ∇_ξ N_a
//! K_ab = Σ_g B_aᵀ D B_b det J w_g            (3×3 block of nodes a, b)
//! M_ab = ρ Σ_g N_a N_b det J w_g · I₃
//! ```
//!
//! `B_a` is the 6×3 strain–displacement matrix of node `a` (strains εxx, εyy, εzz, γxy, γyz,
//! γzx). Mid-edge nodes off the straight edge make the element curved; the rule is then no
//! longer exact, as in every isoparametric code. `det J` must be positive at every node and
//! every quadrature point.

// Index loops follow the index notation of the element formulas.
#![allow(clippy::needless_range_loop)]

use crate::artifact::ElementKind;

use super::topology::reference_node;
use super::{
    Degenerate, ElementMatrices, Location, determinant, inverse, jacobian, packed_index,
    quadrature, shapes,
};

/// Stiffness, consistent mass and volume of an element of `kind` with node coordinates
/// `coords` (m), elasticity `D` (Pa) and density `density` (kg/m³).
pub fn element_matrices(
    kind: ElementKind,
    coords: &[[f64; 3]],
    D: &[[f64; 6]; 6],
    density: f64,
) -> Result<ElementMatrices, Degenerate> {
    let n = kind.n_nodes();
    let mut values = vec![0.0; n];
    let mut gradients = vec![[0.0; 3]; n];
    for node in 0..n {
        shapes::evaluate(
            kind,
            reference_node(kind, node),
            &mut values,
            &mut gradients,
        );
        let det_j = determinant(&jacobian(coords, &gradients));
        if !(det_j > 0.0) {
            return Err(Degenerate {
                det_j,
                location: Location::Node(node),
            });
        }
    }

    let n_dofs = 3 * n;
    // Upper blocks (a ≤ b) of K, full 3×3 each, by node pair; the mass by node pair.
    let mut K = vec![0.0; n_dofs * n_dofs];
    let mut mass = vec![0.0; n * n];
    let mut volume = 0.0;
    let mut physical = vec![[0.0; 3]; n];
    let mut D_B = vec![[[0.0; 3]; 6]; n];
    for (point, rule_point) in quadrature::rule(kind).iter().enumerate() {
        shapes::evaluate(kind, rule_point.xi, &mut values, &mut gradients);
        let J = jacobian(coords, &gradients);
        let det_j = determinant(&J);
        if !(det_j > 0.0) {
            return Err(Degenerate {
                det_j,
                location: Location::QuadraturePoint(point),
            });
        }
        let J_inverse = inverse(&J, det_j);
        let weight = det_j * rule_point.weight;
        for a in 0..n {
            physical[a] =
                std::array::from_fn(|j| (0..3).map(|i| J_inverse[j][i] * gradients[a][i]).sum());
            let B = node_strain_matrix(physical[a]);
            for s in 0..6 {
                for c in 0..3 {
                    D_B[a][s][c] = (0..6).map(|t| D[s][t] * B[t][c]).sum();
                }
            }
        }
        for b in 0..n {
            for a in 0..=b {
                let B_a = node_strain_matrix(physical[a]);
                for i in 0..3 {
                    for j in 0..3 {
                        let sum: f64 = (0..6).map(|s| B_a[s][i] * D_B[b][s][j]).sum();
                        K[(3 * a + i) * n_dofs + 3 * b + j] += sum * weight;
                    }
                }
                mass[a * n + b] += density * values[a] * values[b] * weight;
            }
        }
        volume += weight;
    }

    let mut stiffness = vec![0.0; n_dofs * (n_dofs + 1) / 2];
    for col in 0..n_dofs {
        for row in 0..=col {
            let value = if row / 3 == col / 3 {
                // Within a node's own block, both triangles were summed: average them so that
                // the assembled K is exactly symmetric.
                0.5 * (K[row * n_dofs + col] + K[col * n_dofs + row])
            } else {
                K[row * n_dofs + col]
            };
            stiffness[packed_index(row, col)] = value;
        }
    }
    let mut packed_mass = vec![0.0; n * (n + 1) / 2];
    for b in 0..n {
        for a in 0..=b {
            packed_mass[packed_index(a, b)] = mass[a * n + b];
        }
    }
    Ok(ElementMatrices {
        stiffness,
        mass: packed_mass,
        volume,
    })
}

/// The 6×3 strain–displacement matrix of one node with physical gradient `(bx, by, bz)`.
fn node_strain_matrix([bx, by, bz]: [f64; 3]) -> [[f64; 3]; 6] {
    [
        [bx, 0.0, 0.0],
        [0.0, by, 0.0],
        [0.0, 0.0, bz],
        [by, bx, 0.0],
        [0.0, bz, by],
        [bz, 0.0, bx],
    ]
}

//! The element interface: every kind of solid element behind one set of functions.
//!
//! A kind ([`ElementKind`], node orders in [`crate::artifact::mesh`]) is a row in three tables:
//! its shape functions ([`shapes`]), its quadrature rule ([`quadrature`]) and its reference
//! nodes, edges and faces ([`topology`]). Element matrices come from the isoparametric
//! displacement formulation ([`isoparametric`]) for every kind but the 8-node hexahedron, which
//! keeps its incompatible modes ([`hex8`]). Adding a kind means a row in each table and, in
//! the readers, its node order in each file format.
//!
//! Conventions shared by all kinds: `J_ij = ∂x_j/∂ξ_i`; element DOF `3 a + d` is node `a`'s
//! displacement along direction `d`; matrices are stored as packed upper triangles by columns
//! ([`packed_index`]); the mass is `M_ab · I₃` with the scalar `M_ab` stored.

pub mod formats;
pub mod hex8;
pub mod isoparametric;
pub mod quadrature;
pub mod shapes;
pub mod topology;

#[cfg(test)]
mod tests;

pub use crate::artifact::ElementKind;

use crate::artifact::material::{Elasticity, Material};
use crate::value::StageError;

/// Index of entry (i, j) in a packed upper triangle stored by columns.
#[inline]
pub fn packed_index(row: usize, col: usize) -> usize {
    let (low, high) = if row <= col { (row, col) } else { (col, row) };
    high * (high + 1) / 2 + low
}

/// Where an element's Jacobian determinant was found non-positive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Location {
    /// A corner of an 8-node hexahedron.
    Corner(usize),
    /// A node (corner or mid-edge) of another kind.
    Node(usize),
    /// A point of the 8-node hexahedron's 2×2×2 rule.
    GaussPoint(usize),
    /// A point of the kind's quadrature rule.
    QuadraturePoint(usize),
    Centre,
}

impl std::fmt::Display for Location {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Location::Corner(corner) => write!(f, "corner {corner}"),
            Location::Node(node) => write!(f, "node {node}"),
            Location::GaussPoint(point) => write!(f, "Gauss point {point}"),
            Location::QuadraturePoint(point) => write!(f, "quadrature point {point}"),
            Location::Centre => f.write_str("centre"),
        }
    }
}

/// An inverted or degenerate element: `det J ≤ 0` somewhere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Degenerate {
    pub det_j: f64,
    pub location: Location,
}

/// The matrices of one element of `n` nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct ElementMatrices {
    /// Stiffness `K` (3n×3n), packed upper triangle; exactly symmetric.
    pub stiffness: Vec<f64>,
    /// `ρ ∫ N_a N_b dV` (n×n), packed upper triangle; the mass is this times `I₃`.
    pub mass: Vec<f64>,
    /// `∫ dV` (m³).
    pub volume: f64,
}

/// Stiffness, consistent mass and volume of an element of `kind` with node coordinates
/// `coords` (m, `kind.n_nodes()` of them), elasticity `D` (Pa) and density (kg/m³).
pub fn element_matrices(
    kind: ElementKind,
    coords: &[[f64; 3]],
    D: &[[f64; 6]; 6],
    density: f64,
) -> Result<ElementMatrices, Degenerate> {
    match kind {
        ElementKind::Hex8 => {
            let corners: &[[f64; 3]; 8] = coords.try_into().expect("a hexahedron has 8 nodes");
            hex8::element_matrices(corners, D, density)
        }
        _ => isoparametric::element_matrices(kind, coords, D, density),
    }
}

/// `J_ij = ∂x_j/∂ξ_i` from the nodes' coordinates and reference gradients.
fn jacobian(coords: &[[f64; 3]], gradients: &[[f64; 3]]) -> [[f64; 3]; 3] {
    let mut J = [[0.0; 3]; 3];
    for (gradient, x) in gradients.iter().zip(coords) {
        for i in 0..3 {
            for j in 0..3 {
                J[i][j] += gradient[i] * x[j];
            }
        }
    }
    J
}

fn determinant(J: &[[f64; 3]; 3]) -> f64 {
    J[0][0] * (J[1][1] * J[2][2] - J[1][2] * J[2][1])
        - J[0][1] * (J[1][0] * J[2][2] - J[1][2] * J[2][0])
        + J[0][2] * (J[1][0] * J[2][1] - J[1][1] * J[2][0])
}

fn inverse(J: &[[f64; 3]; 3], det: f64) -> [[f64; 3]; 3] {
    let cofactor =
        |r0: usize, r1: usize, c0: usize, c1: usize| J[r0][c0] * J[r1][c1] - J[r0][c1] * J[r1][c0];
    [
        [
            cofactor(1, 2, 1, 2) / det,
            -cofactor(0, 2, 1, 2) / det,
            cofactor(0, 1, 1, 2) / det,
        ],
        [
            -cofactor(1, 2, 0, 2) / det,
            cofactor(0, 2, 0, 2) / det,
            -cofactor(0, 1, 0, 2) / det,
        ],
        [
            cofactor(1, 2, 0, 1) / det,
            -cofactor(0, 2, 0, 1) / det,
            cofactor(0, 1, 0, 1) / det,
        ],
    ]
}

/// `det J` of the element's map at reference point `xi`.
pub fn det_j_at(kind: ElementKind, coords: &[[f64; 3]], xi: [f64; 3]) -> f64 {
    let n = kind.n_nodes();
    let (mut values, mut gradients) = (vec![0.0; n], vec![[0.0; 3]; n]);
    shapes::evaluate(kind, xi, &mut values, &mut gradients);
    determinant(&jacobian(coords, &gradients))
}

/// The first place where `det J ≤ 0`, with its value: the nodes (the corners of an 8-node
/// hexahedron), then the points of the kind's rule. `None` for a valid element.
pub fn first_inverted(kind: ElementKind, coords: &[[f64; 3]]) -> Option<Degenerate> {
    let nodes = (0..kind.n_nodes()).map(|node| {
        let location = match kind {
            ElementKind::Hex8 => Location::Corner(node),
            _ => Location::Node(node),
        };
        (topology::reference_node(kind, node), location)
    });
    let points = quadrature::rule(kind)
        .iter()
        .enumerate()
        .map(|(point, rule_point)| (rule_point.xi, Location::QuadraturePoint(point)));
    nodes.chain(points).find_map(|(xi, location)| {
        let det_j = det_j_at(kind, coords, xi);
        (!(det_j > 0.0)).then_some(Degenerate { det_j, location })
    })
}

/// The strain of a displacement gradient `g = ∂u_i/∂x_j` in the Voigt order of the elasticity
/// matrices (xx, yy, zz, xy, yz, zx), shears engineering (γ_xy = g_xy + g_yx).
pub fn engineering_strain(g: &[[f64; 3]; 3]) -> [f64; 6] {
    [
        g[0][0],
        g[1][1],
        g[2][2],
        g[0][1] + g[1][0],
        g[1][2] + g[2][1],
        g[2][0] + g[0][2],
    ]
}

/// The displacement gradient `∂u_i/∂x_j` at the element's centre, from its nodal
/// displacements: the compatible part of the strain, a material-free estimate of its size.
/// `None` for an element inverted at its centre.
pub fn centre_displacement_gradient(
    kind: ElementKind,
    coords: &[[f64; 3]],
    displacement: &[[f64; 3]],
) -> Option<[[f64; 3]; 3]> {
    let n = kind.n_nodes();
    let (mut values, mut gradients) = (vec![0.0; n], vec![[0.0; 3]; n]);
    shapes::evaluate(
        kind,
        topology::reference_centre(kind),
        &mut values,
        &mut gradients,
    );
    let J = jacobian(coords, &gradients);
    let det = determinant(&J);
    if det <= 0.0 {
        return None;
    }
    // ∇_ξ N = J ∇_x N.
    let inverse = inverse(&J, det);
    let mut gradient = [[0.0; 3]; 3];
    for (u, reference) in displacement.iter().zip(&gradients) {
        let physical: [f64; 3] =
            std::array::from_fn(|j| (0..3).map(|k| inverse[j][k] * reference[k]).sum());
        for i in 0..3 {
            for j in 0..3 {
                gradient[i][j] += u[i] * physical[j];
            }
        }
    }
    Some(gradient)
}

/// The elasticity of `material` in an element of `kind` with node coordinates `coords`: at the
/// element's centre, where the material's axes vary in space.
pub fn element_elasticity(
    material: &Material,
    kind: ElementKind,
    coords: &[[f64; 3]],
) -> Result<Elasticity, StageError> {
    let corners = &coords[..kind.n_corners()];
    let mut centre = [0.0; 3];
    for corner in corners {
        for axis in 0..3 {
            centre[axis] += corner[axis] / corners.len() as f64;
        }
    }
    material.elasticity_at(centre)
}

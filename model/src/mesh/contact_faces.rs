//! Normals and tributary areas of contact nodes, from the bilinear quadrangle faces of a
//! contact surface (shared by `mesh.brake` and `mesh.gmsh`).
//!
//! For node `i` of the surface, over the faces that hold it,
//!
//! ```text
//! nᵢ ∝ Σ_faces ∫ Nᵢ n dA,        Aᵢ = Σ_faces ∫ Nᵢ dA
//! ```
//!
//! with `Nᵢ` the bilinear shape function of the face: the consistent load of a uniform pressure
//! and its direction. The areas add up to the surface's area (the `Nᵢ` sum to one).

use std::collections::HashMap;

use crate::artifact::mesh::{cross, norm};

/// Per node: `Σ ∫ Nᵢ n dA` and `Σ ∫ Nᵢ dA` over the faces integrated so far.
#[derive(Debug, Default)]
pub struct FaceIntegrals {
    pub normal_sums: HashMap<u32, [f64; 3]>,
    pub area_sums: HashMap<u32, f64>,
}

impl FaceIntegrals {
    /// Adds one face, its nodes ordered counter-clockwise seen from the side `n` points to.
    pub fn add(&mut self, nodes: [u32; 4], corners: &[[f64; 3]; 4]) {
        // 2×2 Gauss points integrate Nᵢ (x_ξ × x_η) exactly on a bilinear quadrangle.
        let gauss = 1.0 / 3f64.sqrt();
        for (xi, eta) in [
            (-gauss, -gauss),
            (gauss, -gauss),
            (gauss, gauss),
            (-gauss, gauss),
        ] {
            let (shape, normal_da) = quad_tangents(corners, xi, eta);
            let da = norm(normal_da);
            for (local, node) in nodes.iter().enumerate() {
                let sum = self.normal_sums.entry(*node).or_insert([0.0; 3]);
                for axis in 0..3 {
                    sum[axis] += shape[local] * normal_da[axis];
                }
                *self.area_sums.entry(*node).or_insert(0.0) += shape[local] * da;
            }
        }
    }

    /// The unit normal and tributary area of `node`; `None` if it is on no face or its faces'
    /// normals cancel out.
    pub fn normal_and_area(&self, node: u32) -> Option<([f64; 3], f64)> {
        let normal_sum = self.normal_sums.get(&node)?;
        let length = norm(*normal_sum);
        (length > 0.0 && length.is_finite())
            .then(|| (normal_sum.map(|c| c / length), self.area_sums[&node]))
    }
}

/// Shape functions of a bilinear quadrangle at (ξ, η) and x_ξ × x_η (normal times dA/dξdη).
pub fn quad_tangents(corners: &[[f64; 3]; 4], xi: f64, eta: f64) -> ([f64; 4], [f64; 3]) {
    const REFERENCE: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
    let mut shape = [0.0; 4];
    let mut d_xi = [0.0; 3];
    let mut d_eta = [0.0; 3];
    for (node, [xi_n, eta_n]) in REFERENCE.iter().enumerate() {
        shape[node] = (1.0 + xi * xi_n) * (1.0 + eta * eta_n) / 4.0;
        for axis in 0..3 {
            d_xi[axis] += corners[node][axis] * xi_n * (1.0 + eta * eta_n) / 4.0;
            d_eta[axis] += corners[node][axis] * eta_n * (1.0 + xi * xi_n) / 4.0;
        }
    }
    (shape, cross(d_xi, d_eta))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_trapezoid_gives_each_corner_its_consistent_share() {
        // Trapezoid with parallel sides 2 (y = 0) and 1 (y = 1), in the xy plane: area 1.5.
        // ∫ Nᵢ dA by hand: the long side's corners get 5/12 each, the short side's 1/3.
        let corners = [
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [1.5, 1.0, 0.0],
            [0.5, 1.0, 0.0],
        ];
        let mut integrals = FaceIntegrals::default();
        integrals.add([0, 1, 2, 3], &corners);
        for (node, expected) in [
            (0, 5.0 / 12.0),
            (1, 5.0 / 12.0),
            (2, 1.0 / 3.0),
            (3, 1.0 / 3.0),
        ] {
            let (normal, area) = integrals.normal_and_area(node).unwrap();
            assert!((area - expected).abs() < 1e-14, "node {node}: {area}");
            assert_eq!(normal, [0.0, 0.0, 1.0]);
        }
        assert!(integrals.normal_and_area(7).is_none());
    }
}

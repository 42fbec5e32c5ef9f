//! The faces of elements, the faces a set of nodes covers (what surfaces, loads and contact
//! interfaces are made of), and the consistent load of a pressure on a face.
//!
//! A face of any shape ([`FaceKind`]) maps the reference triangle (u, v ≥ 0, u + v ≤ 1) or
//! square [−1, 1]² as `x(u, v) = Σ_a N_a(u, v) x_a`, with the element's shape functions
//! restricted to the face:
//!
//! ```text
//! tri3:  N_a = L_a                      tri6:  L_a (2 L_a − 1), 4 L_a L_b at mid-edges
//! quad4: ¼ (1 + u u_a)(1 + v v_a)       quad8: ¼ (1 + u u_a)(1 + v v_a)(u u_a + v v_a − 1),
//!                                              ½ (1 − u²)(1 + v v_a) at mid-edges (and likewise)
//! ```
//!
//! A pressure p pushes into the body along −n (n the outward normal) and node a receives
//! `f_a = −p ∫ N_a (x_u × x_v) du dv`. On a face of straight edges with its mid-edge nodes at
//! their middles, x is linear (triangles) or bilinear (squares), so the integrand is of degree
//! ≤ 2 (tri3), ≤ 4 (tri6) or ≤ 3 per coordinate (quad8): the 6-point degree-4 triangle rule and
//! 3×3 Gauss integrate it exactly, and Σ_a f_a = −p × (area vector). The corner loads of a
//! quadratic face are zero (tri6) or negative (quad8) under a uniform pressure: that is the
//! consistent load, not an error.

use std::collections::BTreeMap;

use crate::artifact::mesh::{Mesh, cross};
use crate::element::quadrature;
use crate::element::topology::{self, FaceKind};

/// One side of the interface: its name (for messages) and its nodes, sorted.
pub struct Side<'a> {
    pub name: &'a str,
    pub nodes: Vec<u32>,
}

impl<'a> Side<'a> {
    pub fn new(name: &'a str, nodes: impl IntoIterator<Item = u32>) -> Self {
        let mut nodes: Vec<u32> = nodes.into_iter().collect();
        nodes.sort_unstable();
        nodes.dedup();
        Side { name, nodes }
    }

    pub fn contains(&self, node: u32) -> bool {
        self.nodes.binary_search(&node).is_ok()
    }
}

/// A face of one element: the element, the face's number in it (Abaqus's S1 is 0), its shape
/// and its nodes in the face's order ([`topology::face_nodes`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ElementFace {
    pub element: usize,
    pub face: usize,
    pub kind: FaceKind,
    pub nodes: Vec<u32>,
}

/// The nodes of face `face` of element `element`.
pub fn element_face(mesh: &Mesh, element: usize, face: usize) -> ElementFace {
    let of = mesh.elements.get(element);
    ElementFace {
        element,
        face,
        kind: topology::face_kind(of.kind, face),
        nodes: topology::face_nodes(of.kind, face)
            .into_iter()
            .map(|local| of.nodes[local])
            .collect(),
    }
}

/// The element faces whose nodes are all in `side`, keyed by their sorted nodes, with the
/// elements that have them (one element for a face on the boundary), in element order.
pub fn faces_within(mesh: &Mesh, side: &Side) -> BTreeMap<Vec<u32>, Vec<ElementFace>> {
    let mut faces: BTreeMap<Vec<u32>, Vec<ElementFace>> = BTreeMap::new();
    for (element, of) in mesh.elements.iter().enumerate() {
        for face in 0..topology::n_faces(of.kind) {
            let local = topology::face_nodes(of.kind, face);
            if local.iter().all(|&a| side.contains(of.nodes[a])) {
                let face = element_face(mesh, element, face);
                let mut key = face.nodes.clone();
                key.sort_unstable();
                faces.entry(key).or_default().push(face);
            }
        }
    }
    faces
}

/// Face shape functions and their derivatives along u and v at `(u, v)`.
pub fn face_shapes(kind: FaceKind, point: [f64; 2]) -> (Vec<f64>, Vec<[f64; 2]>) {
    let mut values = vec![0.0; kind.n_nodes()];
    let mut derivatives = vec![[0.0; 2]; kind.n_nodes()];
    face_shapes_into(kind, point, &mut values, &mut derivatives);
    (values, derivatives)
}

/// [`face_shapes`] into the first `kind.n_nodes()` slots of caller-owned buffers, for the loops
/// that evaluate faces millions of times (mortar segments, projections).
#[inline]
pub fn face_shapes_into(
    kind: FaceKind,
    [u, v]: [f64; 2],
    values: &mut [f64],
    derivatives: &mut [[f64; 2]],
) {
    match kind {
        FaceKind::Tri3 => {
            values[..3].copy_from_slice(&[1.0 - u - v, u, v]);
            derivatives[..3].copy_from_slice(&[[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]]);
        }
        FaceKind::Tri6 => {
            let l = [1.0 - u - v, u, v];
            let dl = [[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]];
            for a in 0..3 {
                values[a] = l[a] * (2.0 * l[a] - 1.0);
                derivatives[a] = dl[a].map(|d| (4.0 * l[a] - 1.0) * d);
            }
            for (slot, (a, b)) in [(0, 1), (1, 2), (2, 0)].into_iter().enumerate() {
                values[3 + slot] = 4.0 * l[a] * l[b];
                derivatives[3 + slot] = [
                    4.0 * (l[b] * dl[a][0] + l[a] * dl[b][0]),
                    4.0 * (l[b] * dl[a][1] + l[a] * dl[b][1]),
                ];
            }
        }
        FaceKind::Quad4 => {
            for (a, &[ua, va]) in QUAD_CORNERS.iter().enumerate() {
                let (fu, fv) = (1.0 + u * ua, 1.0 + v * va);
                values[a] = 0.25 * fu * fv;
                derivatives[a] = [0.25 * ua * fv, 0.25 * va * fu];
            }
        }
        FaceKind::Quad8 => {
            for (a, &[ua, va]) in QUAD_CORNERS.iter().enumerate() {
                let (fu, fv) = (1.0 + u * ua, 1.0 + v * va);
                let sum = u * ua + v * va - 1.0;
                values[a] = 0.25 * fu * fv * sum;
                derivatives[a] = [0.25 * ua * fv * (sum + fu), 0.25 * va * fu * (sum + fv)];
            }
            // Mid-edge nodes of the edges (0 1), (1 2), (2 3), (3 0).
            for (slot, [ua, va]) in [[0.0, -1.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]]
                .into_iter()
                .enumerate()
            {
                if ua == 0.0 {
                    let fv = 1.0 + v * va;
                    values[4 + slot] = 0.5 * (1.0 - u * u) * fv;
                    derivatives[4 + slot] = [-u * fv, 0.5 * (1.0 - u * u) * va];
                } else {
                    let fu = 1.0 + u * ua;
                    values[4 + slot] = 0.5 * fu * (1.0 - v * v);
                    derivatives[4 + slot] = [0.5 * ua * (1.0 - v * v), -v * fu];
                }
            }
        }
    }
}

/// Reference corners of the square face.
const QUAD_CORNERS: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];

/// `∫ N_a (x_u × x_v) du dv` for each node of a face with node coordinates `coords`, and
/// their sum (the area vector, normal by the right-hand rule of the face's node cycle).
pub fn area_vectors(kind: FaceKind, coords: &[[f64; 3]]) -> (Vec<[f64; 3]>, [f64; 3]) {
    let nodal = match kind {
        FaceKind::Quad4 => {
            let corners: &[[f64; 3]; 4] = coords.try_into().expect("a quad4 face has 4 nodes");
            bilinear_area_vectors(corners).to_vec()
        }
        _ => {
            let mut nodal = vec![[0.0; 3]; kind.n_nodes()];
            for ([u, v], weight) in face_rule(kind) {
                let (values, derivatives) = face_shapes(kind, [u, v]);
                let (mut x_u, mut x_v) = ([0.0; 3], [0.0; 3]);
                for (x, d) in coords.iter().zip(&derivatives) {
                    for axis in 0..3 {
                        x_u[axis] += d[0] * x[axis];
                        x_v[axis] += d[1] * x[axis];
                    }
                }
                let normal = cross(x_u, x_v);
                for (vector, value) in nodal.iter_mut().zip(&values) {
                    for axis in 0..3 {
                        vector[axis] += weight * value * normal[axis];
                    }
                }
            }
            nodal
        }
    };
    let mut total = [0.0; 3];
    for vector in &nodal {
        for axis in 0..3 {
            total[axis] += vector[axis];
        }
    }
    (nodal, total)
}

/// The rule of each face shape: the 6-point degree-4 triangle rule, 3×3 Gauss on the square.
fn face_rule(kind: FaceKind) -> Vec<([f64; 2], f64)> {
    match kind {
        FaceKind::Tri3 | FaceKind::Tri6 => quadrature::TRIANGLE_DEGREE_4.clone(),
        FaceKind::Quad4 | FaceKind::Quad8 => quadrature::GAUSS_3
            .iter()
            .flat_map(|&(v, wv)| {
                quadrature::GAUSS_3
                    .iter()
                    .map(move |&(u, wu)| ([u, v], wu * wv))
            })
            .collect(),
    }
}

/// The bilinear face by 2 × 2 Gauss points (exact: the integrand is of degree ≤ 2 in each of
/// u, v), written out as the hexahedral meshes have always been loaded.
fn bilinear_area_vectors(corners: &[[f64; 3]; 4]) -> [[f64; 3]; 4] {
    let gauss = 1.0 / 3f64.sqrt();
    let mut nodal = [[0.0; 3]; 4];
    for (xi, eta) in [
        (-gauss, -gauss),
        (gauss, -gauss),
        (gauss, gauss),
        (-gauss, gauss),
    ] {
        let (mut x_xi, mut x_eta) = ([0.0; 3], [0.0; 3]);
        for (corner, [xi_a, eta_a]) in corners.iter().zip(QUAD_CORNERS) {
            for axis in 0..3 {
                x_xi[axis] += corner[axis] * 0.25 * xi_a * (1.0 + eta * eta_a);
                x_eta[axis] += corner[axis] * 0.25 * eta_a * (1.0 + xi * xi_a);
            }
        }
        let normal = cross(x_xi, x_eta);
        for (vector, [xi_a, eta_a]) in nodal.iter_mut().zip(QUAD_CORNERS) {
            // Gauss weights are 1.
            let shape = 0.25 * (1.0 + xi * xi_a) * (1.0 + eta * eta_a);
            for axis in 0..3 {
                vector[axis] += shape * normal[axis];
            }
        }
    }
    nodal
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat face of each shape on the plane z = 0.1, its corners a parallelogram (squares)
    /// or a triangle, mid-edge nodes at the middles: nodal vectors and their sum.
    fn flat(kind: FaceKind) -> (Vec<[f64; 3]>, [f64; 3], f64) {
        let corners: Vec<[f64; 3]> = match kind.n_corners() {
            3 => vec![[0.0, 0.0, 0.1], [0.3, 0.05, 0.1], [0.1, 0.2, 0.1]],
            _ => vec![
                [0.0, 0.0, 0.1],
                [0.3, 0.0, 0.1],
                [0.4, 0.2, 0.1],
                [0.1, 0.2, 0.1],
            ],
        };
        let mut coords = corners.clone();
        if kind.n_nodes() > kind.n_corners() {
            for a in 0..corners.len() {
                let b = (a + 1) % corners.len();
                coords.push(std::array::from_fn(|i| {
                    0.5 * (corners[a][i] + corners[b][i])
                }));
            }
        }
        let area = match kind.n_corners() {
            3 => 0.5 * (0.3 * 0.2 - 0.05 * 0.1),
            _ => 0.3 * 0.2,
        };
        let (nodal, total) = area_vectors(kind, &coords);
        (
            nodal.into_iter().map(|v| v.map(|c| c / area)).collect(),
            total,
            area,
        )
    }

    #[test]
    fn a_flat_face_loads_its_nodes_with_the_consistent_shares_of_its_area() {
        // Shares of the area on a flat face of straight edges (counter-clockwise: +z):
        // tri3 1/3 each; tri6 0 at corners, 1/3 at mid-edges; quad4 (parallelogram) 1/4;
        // quad8 −1/12 at corners, 1/3 at mid-edges.
        let expected: [(FaceKind, &[f64]); 4] = [
            (FaceKind::Tri3, &[1.0 / 3.0; 3]),
            (
                FaceKind::Tri6,
                &[0.0, 0.0, 0.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
            ),
            (FaceKind::Quad4, &[0.25; 4]),
            (
                FaceKind::Quad8,
                &[
                    -1.0 / 12.0,
                    -1.0 / 12.0,
                    -1.0 / 12.0,
                    -1.0 / 12.0,
                    1.0 / 3.0,
                    1.0 / 3.0,
                    1.0 / 3.0,
                    1.0 / 3.0,
                ],
            ),
        ];
        for (kind, shares) in expected {
            let (nodal, total, area) = flat(kind);
            assert!(
                (total[2] - area).abs() < 1e-15 && total[0].abs() < 1e-16,
                "{kind}"
            );
            for (vector, share) in nodal.iter().zip(shares) {
                assert!(
                    (vector[2] - share).abs() < 1e-14,
                    "{kind}: {vector:?} vs {share}"
                );
                assert!(vector[0].abs() < 1e-14 && vector[1].abs() < 1e-14, "{kind}");
            }
        }
    }

    #[test]
    fn face_shape_functions_interpolate_their_nodes() {
        let nodes = |kind: FaceKind| -> Vec<[f64; 2]> {
            match kind {
                FaceKind::Tri3 => vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
                FaceKind::Tri6 => vec![
                    [0.0, 0.0],
                    [1.0, 0.0],
                    [0.0, 1.0],
                    [0.5, 0.0],
                    [0.5, 0.5],
                    [0.0, 0.5],
                ],
                FaceKind::Quad4 => QUAD_CORNERS.to_vec(),
                FaceKind::Quad8 => {
                    let mut all = QUAD_CORNERS.to_vec();
                    all.extend([[0.0, -1.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]]);
                    all
                }
            }
        };
        for kind in [
            FaceKind::Tri3,
            FaceKind::Tri6,
            FaceKind::Quad4,
            FaceKind::Quad8,
        ] {
            for (a, point) in nodes(kind).into_iter().enumerate() {
                let (values, derivatives) = face_shapes(kind, point);
                for (b, value) in values.iter().enumerate() {
                    let expected = if a == b { 1.0 } else { 0.0 };
                    assert!((value - expected).abs() < 1e-15, "{kind} N_{b}(x_{a})");
                }
                for d in 0..2 {
                    let sum: f64 = derivatives.iter().map(|g| g[d]).sum();
                    assert!(sum.abs() < 1e-14, "{kind}");
                }
            }
        }
    }
}

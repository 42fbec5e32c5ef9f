//! Shape functions `N_a(ξ)` and their reference gradients `∂N_a/∂ξ_i` of every kind, node
//! orders of [`crate::artifact::mesh`].
//!
//! Tetrahedra use the barycentric coordinates `L = (1 − r − s − t, r, s, t)`:
//!
//! ```text
//! tet4:   N_a = L_a
//! tet10:  N_a = L_a (2 L_a − 1) at corners,   N_ab = 4 L_a L_b at the middle of edge (a, b)
//! ```
//!
//! Wedges take the triangle's `L = (1 − r − s, r, s)` times a function of `ζ ∈ [−1, 1]`; `ζ_a`
//! is −1 for corners 0–2 and +1 for corners 3–5:
//!
//! ```text
//! wedge6:   N_a = ½ L_a (1 + ζ_a ζ)
//! wedge15:  N_a = ½ L_a (2 L_a − 1)(1 + ζ_a ζ) − ½ L_a (1 − ζ²)      corners
//!           N_ab = 2 L_a L_b (1 + ζ_k ζ)                              triangle edges at ζ_k
//!           N_a3 = L_a (1 − ζ²)                                       vertical edges
//! ```
//!
//! Hexahedra, with `(ξ_a, η_a, ζ_a)` the node's reference coordinates (corners ±1):
//!
//! ```text
//! hex8:   N_a = ⅛ (1 + ξ ξ_a)(1 + η η_a)(1 + ζ ζ_a)
//! hex20:  N_a = ⅛ (1 + ξ ξ_a)(1 + η η_a)(1 + ζ ζ_a)(ξ ξ_a + η η_a + ζ ζ_a − 2)   corners
//!         N_a = ¼ (1 − ξ²)(1 + η η_a)(1 + ζ ζ_a)   mid-edge nodes with ξ_a = 0 (and likewise)
//! ```

use crate::artifact::ElementKind;

use super::hex8;
use super::topology::{edges, reference_node};

/// Values and reference gradients of the shape functions of `kind` at `xi`, into slices of
/// `kind.n_nodes()` entries.
pub fn evaluate(kind: ElementKind, xi: [f64; 3], values: &mut [f64], gradients: &mut [[f64; 3]]) {
    match kind {
        ElementKind::Hex8 => {
            values.copy_from_slice(&hex8::shape_values(xi));
            gradients.copy_from_slice(&hex8::shape_gradients(xi));
        }
        ElementKind::Tet4 => tet4(xi, values, gradients),
        ElementKind::Tet10 => tet10(xi, values, gradients),
        ElementKind::Wedge6 => wedge6(xi, values, gradients),
        ElementKind::Wedge15 => wedge15(xi, values, gradients),
        ElementKind::Hex20 => hex20(xi, values, gradients),
    }
}

/// Tetrahedral barycentric coordinates and their (constant) reference gradients.
fn tetrahedral([r, s, t]: [f64; 3]) -> ([f64; 4], [[f64; 3]; 4]) {
    (
        [1.0 - r - s - t, r, s, t],
        [
            [-1.0, -1.0, -1.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ],
    )
}

fn tet4(xi: [f64; 3], values: &mut [f64], gradients: &mut [[f64; 3]]) {
    let (l, dl) = tetrahedral(xi);
    values.copy_from_slice(&l);
    gradients.copy_from_slice(&dl);
}

fn tet10(xi: [f64; 3], values: &mut [f64], gradients: &mut [[f64; 3]]) {
    let (l, dl) = tetrahedral(xi);
    for a in 0..4 {
        values[a] = l[a] * (2.0 * l[a] - 1.0);
        gradients[a] = dl[a].map(|d| (4.0 * l[a] - 1.0) * d);
    }
    for (k, &[a, b]) in edges(ElementKind::Tet10).iter().enumerate() {
        values[4 + k] = 4.0 * l[a] * l[b];
        gradients[4 + k] = std::array::from_fn(|i| 4.0 * (l[b] * dl[a][i] + l[a] * dl[b][i]));
    }
}

/// Triangle barycentric coordinates of a wedge and their gradients (no ζ component).
fn triangular([r, s, _]: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    (
        [1.0 - r - s, r, s],
        [[-1.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
    )
}

fn wedge6(xi: [f64; 3], values: &mut [f64], gradients: &mut [[f64; 3]]) {
    let (l, dl) = triangular(xi);
    let zeta = xi[2];
    for level in 0..2 {
        let side = if level == 0 { -1.0 } else { 1.0 };
        let h = 0.5 * (1.0 + side * zeta);
        for a in 0..3 {
            let node = 3 * level + a;
            values[node] = l[a] * h;
            gradients[node] = [dl[a][0] * h, dl[a][1] * h, 0.5 * side * l[a]];
        }
    }
}

fn wedge15(xi: [f64; 3], values: &mut [f64], gradients: &mut [[f64; 3]]) {
    let (l, dl) = triangular(xi);
    let zeta = xi[2];
    let bubble = 1.0 - zeta * zeta;
    for level in 0..2 {
        let side = if level == 0 { -1.0 } else { 1.0 };
        let h = 1.0 + side * zeta;
        for a in 0..3 {
            let node = 3 * level + a;
            values[node] = 0.5 * l[a] * (2.0 * l[a] - 1.0) * h - 0.5 * l[a] * bubble;
            let in_plane = 0.5 * (4.0 * l[a] - 1.0) * h - 0.5 * bubble;
            gradients[node] = [
                in_plane * dl[a][0],
                in_plane * dl[a][1],
                0.5 * l[a] * (2.0 * l[a] - 1.0) * side + l[a] * zeta,
            ];
        }
        // The wedge's first three edges are its bottom triangle's.
        for (k, &[a, b]) in edges(ElementKind::Wedge15)[..3].iter().enumerate() {
            let node = 6 + 3 * level + k;
            values[node] = 2.0 * l[a] * l[b] * h;
            gradients[node] = [
                2.0 * (l[b] * dl[a][0] + l[a] * dl[b][0]) * h,
                2.0 * (l[b] * dl[a][1] + l[a] * dl[b][1]) * h,
                2.0 * l[a] * l[b] * side,
            ];
        }
    }
    for a in 0..3 {
        values[12 + a] = l[a] * bubble;
        gradients[12 + a] = [dl[a][0] * bubble, dl[a][1] * bubble, -2.0 * l[a] * zeta];
    }
}

fn hex20(xi: [f64; 3], values: &mut [f64], gradients: &mut [[f64; 3]]) {
    for a in 0..20 {
        let x_a = reference_node(ElementKind::Hex20, a);
        // Linear factors f_i = 1 + ξ_i ξ_ai of the coordinates where the node is at ±1, and the
        // quadratic bubble 1 − ξ_i² where it is at 0 (mid-edge nodes).
        let factor: [f64; 3] = std::array::from_fn(|i| {
            if x_a[i] == 0.0 {
                1.0 - xi[i] * xi[i]
            } else {
                1.0 + xi[i] * x_a[i]
            }
        });
        let derivative: [f64; 3] =
            std::array::from_fn(|i| if x_a[i] == 0.0 { -2.0 * xi[i] } else { x_a[i] });
        if a < 8 {
            // ∂N_a/∂ξ_i = ⅛ ξ_ai f_j f_k (S + f_i), with f the linear factors and S the sum.
            let sum = xi[0] * x_a[0] + xi[1] * x_a[1] + xi[2] * x_a[2] - 2.0;
            values[a] = 0.125 * factor[0] * factor[1] * factor[2] * sum;
            gradients[a] = std::array::from_fn(|i| {
                let (j, k) = ((i + 1) % 3, (i + 2) % 3);
                0.125 * x_a[i] * factor[j] * factor[k] * (sum + factor[i])
            });
        } else {
            values[a] = 0.25 * factor[0] * factor[1] * factor[2];
            gradients[a] = std::array::from_fn(|i| {
                let (j, k) = ((i + 1) % 3, (i + 2) % 3);
                0.25 * derivative[i] * factor[j] * factor[k]
            });
        }
    }
}

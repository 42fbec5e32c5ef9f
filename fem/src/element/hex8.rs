//! The eight-node hexahedron with incompatible modes (Wilson, Taylor, Beresford & Wilson 1976),
//! and its consistent mass matrix.
//!
//! # Geometry
//! Trilinear map from the reference cube (ξ, η, ζ) ∈ [−1, 1]³, node order of [`crate::artifact::mesh`]:
//!
//! ```text
//! N_a(ξ) = ⅛ (1 + ξ ξ_a)(1 + η η_a)(1 + ζ ζ_a),   x(ξ) = Σ_a N_a(ξ) x_a
//! J_ij = ∂x_j/∂ξ_i,   ∇ₓ N_a = J⁻¹ ∇_ξ N_a
//! ```
//!
//! # Incompatible modes
//! The displacement is enriched with three bubble-like modes per component,
//!
//! ```text
//! u(ξ) = Σ_a N_a(ξ) u_a + Σ_k P_k(ξ) α_k,   P_1 = 1 − ξ²,  P_2 = 1 − η²,  P_3 = 1 − ζ²
//! ```
//!
//! which let a single element through the thickness bend without the parasitic shear that locks
//! the plain trilinear hexahedron. The strain is `ε = B u + G α` (6×24 and 6×9).
//! Taylor's correction evaluates the mode derivatives with the Jacobian at the centre `J₀`,
//! scaled by `det J₀ / det J`:
//!
//! ```text
//! G(ξ) = (det J₀ / det J(ξ)) · G₀(ξ),   G₀ built from ∇ₓ P_k = J₀⁻¹ ∇_ξ P_k
//! ```
//!
//! so that `∫ G dV = det J₀ ∫ G₀ dξ = 0`: a constant stress does no work on the modes and the
//! element passes the patch test on any (non-degenerate) shape. With 2×2×2 Gauss points ξ_g
//! (weights 1):
//!
//! ```text
//! K_uu = Σ_g Bᵀ D B det J,   K_uα = Σ_g Bᵀ D G₀ det J₀,   K_αα = Σ_g G₀ᵀ D G₀ det J₀² / det J
//! K    = K_uu − K_uα K_αα⁻¹ K_αu            (static condensation of the 9 internal DOFs)
//! α    = −K_αα⁻¹ K_αu u                       (recovery, for strains and stresses)
//! ```
//!
//! # Mass
//! Consistent, with the compatible shape functions only, `M_ab = ρ ∫ N_a N_b dV · I₃`, by 2×2×2
//! Gauss. The total mass `Σ_ab M_ab = ρ ∫ det J dξ` is exact: `det J` is at most quadratic in
//! each reference coordinate.
//!
//! # Validity
//! `det J > 0` at every Gauss point and every corner, else the element is inverted or
//! degenerate and is rejected.

// Index loops follow the index notation of the element formulas (K_ij = Σ_s B_si (DB)_sj).
#![allow(clippy::needless_range_loop)]

use super::{Degenerate, ElementMatrices, Location, determinant, inverse, jacobian, packed_index};

/// Reference coordinates (ξ, η, ζ) of the eight nodes.
pub const NODE_REFERENCE: [[f64; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
];

/// 1/√3: the 2-point Gauss abscissa (weights 1).
const GAUSS_ABSCISSA: f64 = 0.577_350_269_189_625_8;

/// Shape functions `N_a(ξ)`.
pub fn shape_values(xi: [f64; 3]) -> [f64; 8] {
    std::array::from_fn(|a| {
        let [xa, ya, za] = NODE_REFERENCE[a];
        0.125 * (1.0 + xi[0] * xa) * (1.0 + xi[1] * ya) * (1.0 + xi[2] * za)
    })
}

/// Reference gradients `∂N_a/∂ξ_i`.
pub fn shape_gradients(xi: [f64; 3]) -> [[f64; 3]; 8] {
    std::array::from_fn(|a| {
        let [xa, ya, za] = NODE_REFERENCE[a];
        let (fx, fy, fz) = (1.0 + xi[0] * xa, 1.0 + xi[1] * ya, 1.0 + xi[2] * za);
        [
            0.125 * xa * fy * fz,
            0.125 * ya * fx * fz,
            0.125 * za * fx * fy,
        ]
    })
}

/// The eight Gauss points of the 2×2×2 rule, in node order.
pub fn gauss_points() -> [[f64; 3]; 8] {
    std::array::from_fn(|g| NODE_REFERENCE[g].map(|sign| sign * GAUSS_ABSCISSA))
}

/// Fills the 6×(3·n) strain-displacement matrix of node-like functions with physical gradients
/// `gradients[a]` (a in 0..n): ε = (εxx, εyy, εzz, γxy, γyz, γzx).
fn strain_matrix<const COLS: usize>(gradients: &[[f64; 3]]) -> [[f64; COLS]; 6] {
    let mut B = [[0.0; COLS]; 6];
    for (a, &[bx, by, bz]) in gradients.iter().enumerate() {
        let col = 3 * a;
        B[0][col] = bx;
        B[1][col + 1] = by;
        B[2][col + 2] = bz;
        B[3][col] = by;
        B[3][col + 1] = bx;
        B[4][col + 1] = bz;
        B[4][col + 2] = by;
        B[5][col] = bz;
        B[5][col + 2] = bx;
    }
    B
}

fn times_matrix<const COLS: usize>(D: &[[f64; 6]; 6], B: &[[f64; COLS]; 6]) -> [[f64; COLS]; 6] {
    let mut DB = [[0.0; COLS]; 6];
    for row in 0..6 {
        for k in 0..6 {
            let d = D[row][k];
            if d != 0.0 {
                for col in 0..COLS {
                    DB[row][col] += d * B[k][col];
                }
            }
        }
    }
    DB
}

/// Everything integrated over one element before condensation.
struct Integrated {
    K_uu: [[f64; 24]; 24],
    K_ua: [[f64; 9]; 24],
    K_aa: [[f64; 9]; 9],
    mass: [[f64; 8]; 8],
    volume: f64,
    /// Per Gauss point: `B` and the Taylor-scaled `G = (det J₀/det J) G₀`.
    B: [[[f64; 24]; 6]; 8],
    G: [[[f64; 9]; 6]; 8],
}

fn integrate(
    coords: &[[f64; 3]; 8],
    D: &[[f64; 6]; 6],
    density: f64,
) -> Result<Box<Integrated>, Degenerate> {
    for (corner, reference) in NODE_REFERENCE.iter().enumerate() {
        let det_j = determinant(&jacobian(coords, &shape_gradients(*reference)));
        if !(det_j > 0.0) {
            return Err(Degenerate {
                det_j,
                location: Location::Corner(corner),
            });
        }
    }
    let J0 = jacobian(coords, &shape_gradients([0.0; 3]));
    let det_j0 = determinant(&J0);
    if !(det_j0 > 0.0) {
        return Err(Degenerate {
            det_j: det_j0,
            location: Location::Centre,
        });
    }
    let J0_inverse = inverse(&J0, det_j0);

    let mut element = Box::new(Integrated {
        K_uu: [[0.0; 24]; 24],
        K_ua: [[0.0; 9]; 24],
        K_aa: [[0.0; 9]; 9],
        mass: [[0.0; 8]; 8],
        volume: 0.0,
        B: [[[0.0; 24]; 6]; 8],
        G: [[[0.0; 9]; 6]; 8],
    });
    for (point, xi) in gauss_points().into_iter().enumerate() {
        let reference_gradients = shape_gradients(xi);
        let J = jacobian(coords, &reference_gradients);
        let det_j = determinant(&J);
        if !(det_j > 0.0) {
            return Err(Degenerate {
                det_j,
                location: Location::GaussPoint(point),
            });
        }
        let J_inverse = inverse(&J, det_j);
        let physical_gradients: [[f64; 3]; 8] = std::array::from_fn(|a| {
            std::array::from_fn(|j| {
                (0..3)
                    .map(|i| J_inverse[j][i] * reference_gradients[a][i])
                    .sum()
            })
        });
        // ∇ₓ P_k = J₀⁻¹ ∇_ξ P_k with ∇_ξ P_k = −2 ξ_k e_k.
        let mode_gradients: [[f64; 3]; 3] =
            std::array::from_fn(|k| std::array::from_fn(|j| J0_inverse[j][k] * (-2.0 * xi[k])));
        let B: [[f64; 24]; 6] = strain_matrix(&physical_gradients);
        let G0: [[f64; 9]; 6] = strain_matrix(&mode_gradients);
        let DB = times_matrix(D, &B);
        let DG0 = times_matrix(D, &G0);
        for i in 0..24 {
            for j in 0..24 {
                let mut sum = 0.0;
                for s in 0..6 {
                    sum += B[s][i] * DB[s][j];
                }
                element.K_uu[i][j] += sum * det_j;
            }
            for j in 0..9 {
                let mut sum = 0.0;
                for s in 0..6 {
                    sum += DB[s][i] * G0[s][j];
                }
                element.K_ua[i][j] += sum * det_j0;
            }
        }
        let mode_weight = det_j0 * det_j0 / det_j;
        for i in 0..9 {
            for j in 0..9 {
                let mut sum = 0.0;
                for s in 0..6 {
                    sum += G0[s][i] * DG0[s][j];
                }
                element.K_aa[i][j] += sum * mode_weight;
            }
        }
        let shape = shape_values(xi);
        for a in 0..8 {
            for b in 0..8 {
                element.mass[a][b] += density * shape[a] * shape[b] * det_j;
            }
        }
        element.volume += det_j;
        element.B[point] = B;
        let taylor_scale = det_j0 / det_j;
        element.G[point] = G0.map(|row| row.map(|value| value * taylor_scale));
    }
    Ok(element)
}

/// Cholesky factor `L` (lower) of the 9×9 SPD `K_αα`, or `None` if it is not positive definite.
fn cholesky9(A: &[[f64; 9]; 9]) -> Option<[[f64; 9]; 9]> {
    let mut L = [[0.0; 9]; 9];
    for j in 0..9 {
        let mut diagonal = A[j][j];
        for k in 0..j {
            diagonal -= L[j][k] * L[j][k];
        }
        if !(diagonal > 0.0) {
            return None;
        }
        L[j][j] = diagonal.sqrt();
        for i in j + 1..9 {
            let mut sum = A[i][j];
            for k in 0..j {
                sum -= L[i][k] * L[j][k];
            }
            L[i][j] = sum / L[j][j];
        }
    }
    Some(L)
}

/// Solves `L Lᵀ x = b` in place.
fn cholesky9_solve(L: &[[f64; 9]; 9], b: &mut [f64; 9]) {
    for i in 0..9 {
        let mut sum = b[i];
        for k in 0..i {
            sum -= L[i][k] * b[k];
        }
        b[i] = sum / L[i][i];
    }
    for i in (0..9).rev() {
        let mut sum = b[i];
        for k in i + 1..9 {
            sum -= L[k][i] * b[k];
        }
        b[i] = sum / L[i][i];
    }
}

fn factor_modes(element: &Integrated) -> Result<[[f64; 9]; 9], Degenerate> {
    cholesky9(&element.K_aa).ok_or(Degenerate {
        det_j: 0.0,
        location: Location::Centre,
    })
}

/// Condensed stiffness, consistent mass and volume of the element with node coordinates
/// `coords` (m), elasticity `D` (Pa) and density `density` (kg/m³).
pub fn element_matrices(
    coords: &[[f64; 3]; 8],
    D: &[[f64; 6]; 6],
    density: f64,
) -> Result<ElementMatrices, Degenerate> {
    let element = integrate(coords, D, density)?;
    let L = factor_modes(&element)?;
    // K = K_uu − K_uα K_αα⁻¹ K_αu, one column of K_αα⁻¹ K_αu at a time.
    let mut K = element.K_uu;
    for col in 0..24 {
        let mut condensed: [f64; 9] = element.K_ua[col];
        cholesky9_solve(&L, &mut condensed);
        for row in 0..24 {
            let mut sum = 0.0;
            for k in 0..9 {
                sum += element.K_ua[row][k] * condensed[k];
            }
            K[row][col] -= sum;
        }
    }
    let mut stiffness = vec![0.0; 24 * 25 / 2];
    for col in 0..24 {
        for row in 0..=col {
            // Averaging both triangles makes the assembled K exactly symmetric.
            stiffness[packed_index(row, col)] = 0.5 * (K[row][col] + K[col][row]);
        }
    }
    let mut mass = vec![0.0; 8 * 9 / 2];
    for b in 0..8 {
        for a in 0..=b {
            mass[packed_index(a, b)] = 0.5 * (element.mass[a][b] + element.mass[b][a]);
        }
    }
    Ok(ElementMatrices {
        stiffness,
        mass,
        volume: element.volume,
    })
}

/// Strains `ε = B u + G α` at the eight Gauss points for nodal displacements `displacement`
/// (DOF `3 a + d`), with the internal modes recovered as `α = −K_αα⁻¹ K_αu u`.
pub fn gauss_point_strains(
    coords: &[[f64; 3]; 8],
    D: &[[f64; 6]; 6],
    displacement: &[f64; 24],
) -> Result<[[f64; 6]; 8], Degenerate> {
    let element = integrate(coords, D, 0.0)?;
    let L = factor_modes(&element)?;
    let mut modes = [0.0; 9];
    for (k, mode) in modes.iter_mut().enumerate() {
        *mode = -(0..24)
            .map(|i| element.K_ua[i][k] * displacement[i])
            .sum::<f64>();
    }
    cholesky9_solve(&L, &mut modes);
    Ok(std::array::from_fn(|point| {
        std::array::from_fn(|s| {
            let compatible: f64 = (0..24)
                .map(|i| element.B[point][s][i] * displacement[i])
                .sum();
            let incompatible: f64 = (0..9).map(|k| element.G[point][s][k] * modes[k]).sum();
            compatible + incompatible
        })
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn steel() -> [[f64; 6]; 6] {
        crate::artifact::material::isotropic_elasticity(2.0e11, 0.3)
    }

    fn distorted_coords() -> [[f64; 3]; 8] {
        let mut coords =
            NODE_REFERENCE.map(|[x, y, z]| [0.5 * (x + 1.0), 0.3 * (y + 1.0), 0.2 * (z + 1.0)]);
        coords[6] = [0.62, 0.71, 0.47];
        coords[1][2] -= 0.05;
        coords
    }

    fn stiffness_times(matrices: &ElementMatrices, u: &[f64; 24]) -> [f64; 24] {
        std::array::from_fn(|i| {
            (0..24)
                .map(|j| matrices.stiffness[packed_index(i, j)] * u[j])
                .sum()
        })
    }

    #[test]
    fn rigid_motions_cost_no_energy() {
        let coords = distorted_coords();
        let matrices = element_matrices(&coords, &steel(), 7850.0).unwrap();
        let scale = (0..24)
            .map(|i| matrices.stiffness[packed_index(i, i)].abs())
            .fold(0.0, f64::max);
        let rotation_z: [f64; 24] = std::array::from_fn(|dof| match dof % 3 {
            0 => -coords[dof / 3][1],
            1 => coords[dof / 3][0],
            _ => 0.0,
        });
        let translation_y: [f64; 24] =
            std::array::from_fn(|dof| if dof % 3 == 1 { 1.0 } else { 0.0 });
        for motion in [rotation_z, translation_y] {
            let force = stiffness_times(&matrices, &motion);
            assert!(force.iter().all(|f| f.abs() < 1e-9 * scale), "{force:?}");
        }
    }

    #[test]
    fn mass_and_volume_are_exact_on_a_distorted_element() {
        let coords = distorted_coords();
        let matrices = element_matrices(&coords, &steel(), 2.0).unwrap();
        let total: f64 = (0..8)
            .flat_map(|a| (0..8).map(move |b| (a, b)))
            .map(|(a, b)| matrices.mass[packed_index(a, b)])
            .sum();
        assert!((total - 2.0 * matrices.volume).abs() < 1e-14 * total);
    }

    #[test]
    fn constant_strain_leaves_internal_modes_at_rest() {
        let coords = distorted_coords();
        let strain_field = |x: [f64; 3]| {
            [
                1e-3 * x[0] + 2e-4 * x[1],
                -3e-4 * x[2],
                5e-4 * x[0] + 1e-4 * x[2],
            ]
        };
        let displacement: [f64; 24] =
            std::array::from_fn(|dof| strain_field(coords[dof / 3])[dof % 3]);
        let strains = gauss_point_strains(&coords, &steel(), &displacement).unwrap();
        let expected = [1e-3, 0.0, 1e-4, 2e-4, -3e-4, 5e-4];
        for strain in strains {
            for (got, want) in strain.iter().zip(expected) {
                assert!((got - want).abs() < 1e-15, "{strain:?}");
            }
        }
    }

    #[test]
    fn inverted_element_is_rejected_at_a_corner() {
        let mut coords = distorted_coords();
        coords.swap(0, 1);
        let err = element_matrices(&coords, &steel(), 1.0).unwrap_err();
        assert!(err.det_j <= 0.0);
        assert!(matches!(err.location, Location::Corner(_)));
    }
}

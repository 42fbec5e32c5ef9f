//! A material: its elastic law, density and Rayleigh damping, and the parts of a mesh it
//! fills.
//!
//! # Isotropic
//! Hooke's law in Voigt notation, strains ε = (εxx, εyy, εzz, γxy, γyz, γzx) with engineering
//! shear strains γ = 2ε:
//!
//! ```text
//! σ = D ε,   D = | λ+2μ  λ     λ     0  0  0 |     λ = E ν / ((1 + ν)(1 − 2ν))
//!                | λ     λ+2μ  λ     0  0  0 |     μ = E / (2 (1 + ν))
//!                | λ     λ     λ+2μ  0  0  0 |
//!                | 0     0     0     μ  0  0 |
//!                | 0     0     0     0  μ  0 |
//!                | 0     0     0     0  0  μ |
//! ```
//!
//! Rayleigh damping of a part: `C_part = α M_part + β K_part`.
//!
//! # Orthotropic, in the material frame
//! With axes 1, 2, 3 of the material, Young's moduli `E_i`, Poisson's ratios `ν_ij` (the
//! contraction along `j` under a stress along `i`: `ν_ji / E_j = ν_ij / E_i`) and shear moduli
//! `G_ij`, the strain is `ε = S σ` with
//!
//! ```text
//! S_11 = 1/E_1       S_12 = −ν_12/E_1   S_13 = −ν_13/E_1
//!                    S_22 = 1/E_2       S_23 = −ν_23/E_2
//!                                       S_33 = 1/E_3
//! shear: γ_12 = τ_12 / G_12,   γ_23 = τ_23 / G_23,   γ_13 = τ_13 / G_13
//! ```
//!
//! (symmetric), in the Voigt order the elements use, `(11, 22, 33, 12, 23, 31)` with
//! engineering shear strains `γ = 2ε`. The constants describe a material when `S` is positive
//! definite (all moduli positive and the 3×3 normal block positive definite: `|ν_ij| <
//! √(E_i/E_j)` and `1 − ν_12ν_21 − ν_23ν_32 − ν_13ν_31 − 2ν_21ν_32ν_13 > 0`); then `D = S⁻¹`.
//! Transversely isotropic about axis 3 (friction linings, axis 3 their normal):
//! `E_1 = E_2`, `ν_13 = ν_23`, `G_13 = G_23`, `G_12 = E_1 / (2(1 + ν_12))`.
//!
//! # Rotation to the global frame
//! The frame's axes are the rows of an orthonormal `R` (`e_i = R_i·`), so that a vector's
//! material components are `R v` and a strain tensor's are `R ε Rᵀ`. In Voigt form with
//! engineering shears this is `ε_m = T ε` (the Bond matrix `T`, built column by column from
//! the rotation of each unit strain). The strain energy is the same in both frames,
//! `σ·ε = σ_m·ε_m`, so
//!
//! ```text
//! D_global = Tᵀ D_m T
//! ```
//!
//! # Frames
//! - `global`: the material axes are x, y, z.
//! - `cylindrical`: about an axis through a point: axis 1 radial (away from the axis), axis 2
//!   circumferential (`3 × 1`), axis 3 along the axis: a disc's. It varies from point to
//!   point; an element takes the frame at its centre (the mean of its corners), as Nastran
//!   does for solids, and no element may straddle the axis.
//! - `axes`: axis 3 along a given direction and axis 1 along another (made orthogonal to the
//!   first): any fixed orientation.
//! - `normal`: axis 3 along a given direction (a pad's normal), axes 1 and 2 any two
//!   completing it: only for constants that are transversely isotropic about axis 3, which do
//!   not depend on that choice.

use serde::{Deserialize, Serialize};

use crate::artifact::mesh::{cross, dot, norm, sub};
use crate::value::StageError;

/// An elasticity matrix in Voigt order (xx, yy, zz, xy, yz, zx), engineering shear strains.
pub type Elasticity = [[f64; 6]; 6];

/// A material and the parts of a mesh made of it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// The study's name for it (the stage that declares it, or the part of a short form).
    pub name: String,
    /// The mesh's parts made of it.
    pub parts: Vec<String>,
    pub law: ElasticLaw,
    /// Density ρ (kg/m³).
    pub density: f64,
    /// Mass-proportional damping α (1/s).
    pub alpha: f64,
    /// Stiffness-proportional damping β (s).
    pub beta: f64,
}

/// How a material's stress follows its strain.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum ElasticLaw {
    Isotropic {
        /// Young's modulus E (Pa).
        youngs_modulus: f64,
        /// Poisson's ratio ν.
        poisson_ratio: f64,
    },
    Orthotropic {
        constants: EngineeringConstants,
        frame: Frame,
    },
}

impl Material {
    /// Checks the constants, naming the material in the message.
    pub fn check(&self) -> Result<(), StageError> {
        let name = &self.name;
        if let ElasticLaw::Isotropic {
            youngs_modulus,
            poisson_ratio,
        } = self.law
        {
            if !(youngs_modulus > 0.0 && youngs_modulus.is_finite()) {
                return Err(StageError::new(format!(
                    "material `{name}`: E = {youngs_modulus} Pa: Young's modulus must be positive"
                )));
            }
            if !(poisson_ratio > -1.0 && poisson_ratio < 0.5) {
                return Err(StageError::new(format!(
                    "material `{name}`: nu = {poisson_ratio}: Poisson's ratio must lie in (-1, 0.5)"
                )));
            }
        }
        if let ElasticLaw::Orthotropic { constants, frame } = &self.law {
            constants.check(name)?;
            frame.check(name, constants)?;
        }
        if !(self.density > 0.0 && self.density.is_finite()) {
            return Err(StageError::new(format!(
                "material `{name}`: rho = {} kg/m^3: density must be positive",
                self.density
            )));
        }
        if !(self.alpha.is_finite() && self.beta.is_finite()) {
            return Err(StageError::new(format!(
                "material `{name}`: alpha = {}, beta = {}: damping coefficients must be finite",
                self.alpha, self.beta
            )));
        }
        Ok(())
    }

    /// Whether the elasticity is the same everywhere (every frame but `cylindrical`).
    pub fn is_uniform(&self) -> bool {
        !matches!(
            self.law,
            ElasticLaw::Orthotropic {
                frame: Frame::Cylindrical { .. },
                ..
            }
        )
    }

    /// The elasticity `D` (Pa) in the global frame at point `x` (m).
    pub fn elasticity_at(&self, x: [f64; 3]) -> Result<Elasticity, StageError> {
        match &self.law {
            ElasticLaw::Isotropic {
                youngs_modulus,
                poisson_ratio,
            } => Ok(isotropic_elasticity(*youngs_modulus, *poisson_ratio)),
            ElasticLaw::Orthotropic { constants, frame } => {
                let axes = frame
                    .axes_at(x)
                    .map_err(|err| StageError::new(format!("material `{}`: {err}", self.name)))?;
                Ok(to_global(&constants.material_elasticity(), &axes))
            }
        }
    }
}

/// The isotropic elasticity matrix `D` (Pa) of Young's modulus `E` and Poisson's ratio `ν`.
pub fn isotropic_elasticity(youngs_modulus: f64, poisson_ratio: f64) -> Elasticity {
    let (E, nu) = (youngs_modulus, poisson_ratio);
    let lame_lambda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    let shear_modulus = E / (2.0 * (1.0 + nu));
    let mut D = [[0.0; 6]; 6];
    for row in 0..3 {
        D[row][..3].fill(lame_lambda);
        D[row][row] = lame_lambda + 2.0 * shear_modulus;
        D[row + 3][row + 3] = shear_modulus;
    }
    D
}

/// Orthotropic engineering constants in the material frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EngineeringConstants {
    /// `E_1, E_2, E_3` (Pa).
    pub youngs_moduli: [f64; 3],
    /// `ν_12, ν_13, ν_23`.
    pub poisson_ratios: [f64; 3],
    /// `G_12, G_13, G_23` (Pa).
    pub shear_moduli: [f64; 3],
}

/// The orientation of a material's axes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Frame {
    Global,
    Cylindrical { origin: [f64; 3], axis: [f64; 3] },
    Axes { axis1: [f64; 3], axis3: [f64; 3] },
    Normal { axis3: [f64; 3] },
}

impl EngineeringConstants {
    /// Transversely isotropic about axis 3: in-plane `E`, `ν`; out of plane `E_3`, `ν_13`,
    /// `G_13`. The in-plane shear modulus follows, `G_12 = E / (2(1 + ν))`.
    pub fn transversely_isotropic(
        in_plane: (f64, f64),
        normal: f64,
        poisson_normal: f64,
        shear_normal: f64,
    ) -> EngineeringConstants {
        let (E, nu) = in_plane;
        EngineeringConstants {
            youngs_moduli: [E, E, normal],
            poisson_ratios: [nu, poisson_normal, poisson_normal],
            shear_moduli: [E / (2.0 * (1.0 + nu)), shear_normal, shear_normal],
        }
    }

    /// Isotropic constants as engineering constants.
    pub fn isotropic(youngs_modulus: f64, poisson_ratio: f64) -> EngineeringConstants {
        let G = youngs_modulus / (2.0 * (1.0 + poisson_ratio));
        EngineeringConstants {
            youngs_moduli: [youngs_modulus; 3],
            poisson_ratios: [poisson_ratio; 3],
            shear_moduli: [G; 3],
        }
    }

    /// Whether the constants are the same about every axis perpendicular to axis 3.
    pub fn is_transversely_isotropic(&self) -> bool {
        let [E1, E2, _] = self.youngs_moduli;
        let [nu12, nu13, nu23] = self.poisson_ratios;
        let [G12, G13, G23] = self.shear_moduli;
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * a.abs().max(b.abs());
        close(E1, E2)
            && close(nu13, nu23)
            && close(G13, G23)
            && close(G12, E1 / (2.0 * (1.0 + nu12)))
    }

    /// The compliance's normal block, `S_ij` for i, j in 1..3.
    fn normal_compliance(&self) -> [[f64; 3]; 3] {
        let [E1, E2, E3] = self.youngs_moduli;
        let [nu12, nu13, nu23] = self.poisson_ratios;
        [
            [1.0 / E1, -nu12 / E1, -nu13 / E1],
            [-nu12 / E1, 1.0 / E2, -nu23 / E2],
            [-nu13 / E1, -nu23 / E2, 1.0 / E3],
        ]
    }

    /// Checks that the constants describe a material (`S` positive definite); `name` names
    /// the material in the message.
    pub fn check(&self, name: &str) -> Result<(), StageError> {
        let moduli = self.youngs_moduli.iter().chain(&self.shear_moduli);
        if let Some(bad) = moduli.clone().find(|m| !(**m > 0.0 && m.is_finite())) {
            return Err(StageError::new(format!(
                "material `{name}`: a modulus is {bad} Pa: Young's and shear moduli must be positive (E = {:?}, G = {:?})",
                self.youngs_moduli, self.shear_moduli
            )));
        }
        if self.poisson_ratios.iter().any(|nu| !nu.is_finite()) {
            return Err(StageError::new(format!(
                "material `{name}`: Poisson's ratios {:?} must be finite",
                self.poisson_ratios
            )));
        }
        // Leading minors of the normal block, scaled to be dimensionless.
        let S = self.normal_compliance();
        let [E1, E2, E3] = self.youngs_moduli;
        let scaled = |i: usize, j: usize| S[i][j] * [E1, E2, E3][i].sqrt() * [E1, E2, E3][j].sqrt();
        let minor2 = scaled(0, 0) * scaled(1, 1) - scaled(0, 1) * scaled(1, 0);
        let minor3 = (0..3)
            .map(|col| {
                let (a, b) = ((col + 1) % 3, (col + 2) % 3);
                scaled(0, col) * (scaled(1, a) * scaled(2, b) - scaled(1, b) * scaled(2, a))
            })
            .sum::<f64>();
        if !(minor2 > 0.0 && minor3 > 0.0) {
            return Err(StageError::new(format!(
                "material `{name}`: E = {:?} Pa with ν_12, ν_13, ν_23 = {:?} is not a material: the strain energy would be negative for some stress (|ν_ij| < √(E_i/E_j) and 1 − ν12ν21 − ν23ν32 − ν13ν31 − 2ν21ν32ν13 > 0 are needed; here the last is {minor3:.3e})",
                self.youngs_moduli, self.poisson_ratios
            )));
        }
        Ok(())
    }

    /// `D = S⁻¹` in the material frame, Voigt order (11, 22, 33, 12, 23, 31).
    pub fn material_elasticity(&self) -> Elasticity {
        let S = self.normal_compliance();
        // The inverse of the symmetric 3×3 block by cofactors.
        let cofactor = |i: usize, j: usize| {
            let (r0, r1) = ((i + 1) % 3, (i + 2) % 3);
            let (c0, c1) = ((j + 1) % 3, (j + 2) % 3);
            S[r0][c0] * S[r1][c1] - S[r0][c1] * S[r1][c0]
        };
        let determinant: f64 = (0..3).map(|j| S[0][j] * cofactor(0, j)).sum();
        let mut D = [[0.0; 6]; 6];
        for (i, row) in D.iter_mut().enumerate().take(3) {
            for (j, value) in row.iter_mut().enumerate().take(3) {
                *value = cofactor(j, i) / determinant;
            }
        }
        let [G12, G13, G23] = self.shear_moduli;
        D[3][3] = G12;
        D[4][4] = G23;
        D[5][5] = G13;
        D
    }
}

impl Frame {
    /// Checks the frame's vectors; `name` names the material in the message.
    pub fn check(&self, name: &str, constants: &EngineeringConstants) -> Result<(), StageError> {
        let nonzero = |what: &str, v: [f64; 3]| {
            if v.iter().all(|c| c.is_finite()) && norm(v) > 0.0 {
                Ok(())
            } else {
                Err(StageError::new(format!(
                    "material `{name}`: the frame's {what} is {v:?}: it needs a nonzero direction"
                )))
            }
        };
        match *self {
            Frame::Global => Ok(()),
            Frame::Cylindrical { origin, axis } => {
                if !origin.iter().all(|c| c.is_finite()) {
                    return Err(StageError::new(format!(
                        "material `{name}`: the cylindrical frame's origin {origin:?} is not finite"
                    )));
                }
                nonzero("axis", axis)
            }
            Frame::Axes { axis1, axis3 } => {
                nonzero("axis 1", axis1)?;
                nonzero("axis 3", axis3)?;
                let along = dot(axis1, axis3).abs() / (norm(axis1) * norm(axis3));
                if along > 1.0 - 1e-6 {
                    return Err(StageError::new(format!(
                        "material `{name}`: axis 1 {axis1:?} is parallel to axis 3 {axis3:?}: they must span a plane"
                    )));
                }
                Ok(())
            }
            Frame::Normal { axis3 } => {
                nonzero("normal", axis3)?;
                if !constants.is_transversely_isotropic() {
                    return Err(StageError::new(format!(
                        "material `{name}`: a frame given by its normal fixes axis 3 only, so the constants must be transversely isotropic about it (E_1 = E_2, ν_13 = ν_23, G_13 = G_23, G_12 = E_1/(2(1 + ν_12))); give axis 1 too"
                    )));
                }
                Ok(())
            }
        }
    }

    /// The material axes at point `x`, as the rows of a rotation.
    pub fn axes_at(&self, x: [f64; 3]) -> Result<[[f64; 3]; 3], StageError> {
        let frame_of = |axis3: [f64; 3], axis1: [f64; 3]| {
            let e3 = unit(axis3);
            let e1 = unit(sub(axis1, scale(e3, dot(axis1, e3))));
            [e1, cross(e3, e1), e3]
        };
        match *self {
            Frame::Global => Ok([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
            Frame::Axes { axis1, axis3 } => Ok(frame_of(axis3, axis1)),
            Frame::Normal { axis3 } => {
                // Axis 1 from the global axis least aligned with the normal: any completion
                // gives the same D for transversely isotropic constants.
                let e3 = unit(axis3);
                let least = (0..3)
                    .min_by(|&a, &b| e3[a].abs().total_cmp(&e3[b].abs()))
                    .unwrap_or(0);
                let mut axis1 = [0.0; 3];
                axis1[least] = 1.0;
                Ok(frame_of(axis3, axis1))
            }
            Frame::Cylindrical { origin, axis } => {
                let e3 = unit(axis);
                let offset = sub(x, origin);
                let radial = sub(offset, scale(e3, dot(offset, e3)));
                if norm(radial) <= 1e-12 * norm(offset).max(f64::MIN_POSITIVE) {
                    return Err(StageError::new(format!(
                        "the cylindrical frame has no radial direction at {x:?}, on its axis"
                    )));
                }
                Ok(frame_of(axis, radial))
            }
        }
    }
}

/// The Bond matrix `T` of the rotation whose rows are `axes`: `ε_m = T ε` for engineering
/// Voigt strains (xx, yy, zz, xy, yz, zx).
pub fn strain_rotation(axes: &[[f64; 3]; 3]) -> [[f64; 6]; 6] {
    // Voigt index of each tensor component, and the factor from tensor to engineering strain.
    const PAIRS: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0)];
    let mut T = [[0.0; 6]; 6];
    for (col, &(k, l)) in PAIRS.iter().enumerate() {
        // The tensor of a unit engineering strain in component `col`.
        let mut strain = [[0.0; 3]; 3];
        if k == l {
            strain[k][k] = 1.0;
        } else {
            strain[k][l] = 0.5;
            strain[l][k] = 0.5;
        }
        for (row, &(i, j)) in PAIRS.iter().enumerate() {
            let mut rotated = 0.0;
            for (a, strain_a) in strain.iter().enumerate() {
                for (b, value) in strain_a.iter().enumerate() {
                    rotated += axes[i][a] * axes[j][b] * value;
                }
            }
            T[row][col] = if i == j { rotated } else { 2.0 * rotated };
        }
    }
    T
}

/// `Tᵀ D T`: a material-frame elasticity in the global frame.
pub fn to_global(D: &Elasticity, axes: &[[f64; 3]; 3]) -> Elasticity {
    let T = strain_rotation(axes);
    let mut DT = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in 0..6 {
            DT[i][j] = (0..6).map(|k| D[i][k] * T[k][j]).sum();
        }
    }
    let mut global = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in 0..6 {
            global[i][j] = (0..6).map(|k| T[k][i] * DT[k][j]).sum();
        }
    }
    global
}

fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

fn unit(a: [f64; 3]) -> [f64; 3] {
    scale(a, 1.0 / norm(a))
}

#[cfg(test)]
mod tests;

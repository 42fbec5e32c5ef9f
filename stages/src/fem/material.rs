//! Isotropic linear-elastic materials with Rayleigh damping, one per part.
//!
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

use crate::value::StageError;

/// The part names that carry a material, and the prefix of their parameters.
pub const MATERIAL_PARTS: [&str; 2] = ["disc", "pad"];

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Young's modulus E (Pa).
    pub youngs_modulus: f64,
    /// Poisson's ratio ν.
    pub poisson_ratio: f64,
    /// Density ρ (kg/m³).
    pub density: f64,
    /// Mass-proportional damping α (1/s).
    pub alpha: f64,
    /// Stiffness-proportional damping β (s).
    pub beta: f64,
}

impl Material {
    /// Checks the constants of part `part`, named as its parameters are (`E_disc`, …).
    pub fn check(&self, part: &str) -> Result<(), StageError> {
        if !(self.youngs_modulus > 0.0 && self.youngs_modulus.is_finite()) {
            return Err(StageError::new(format!(
                "E_{part} = {} Pa: Young's modulus must be positive",
                self.youngs_modulus
            )));
        }
        if !(self.poisson_ratio > -1.0 && self.poisson_ratio < 0.5) {
            return Err(StageError::new(format!(
                "nu_{part} = {}: Poisson's ratio must lie in (-1, 0.5)",
                self.poisson_ratio
            )));
        }
        if !(self.density > 0.0 && self.density.is_finite()) {
            return Err(StageError::new(format!(
                "rho_{part} = {} kg/m^3: density must be positive",
                self.density
            )));
        }
        if !(self.alpha.is_finite() && self.beta.is_finite()) {
            return Err(StageError::new(format!(
                "alpha_{part} = {}, beta_{part} = {}: damping coefficients must be finite",
                self.alpha, self.beta
            )));
        }
        Ok(())
    }

    /// The elasticity matrix `D` (Pa) in Voigt notation with engineering shear strains.
    pub fn elasticity(&self) -> [[f64; 6]; 6] {
        let (E, nu) = (self.youngs_modulus, self.poisson_ratio);
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
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn elasticity_gives_uniaxial_stress_modulus() {
        let steel = Material {
            youngs_modulus: 2.0e11,
            poisson_ratio: 0.3,
            density: 7850.0,
            alpha: 0.0,
            beta: 0.0,
        };
        let D = steel.elasticity();
        // Uniaxial stress: ε = (1, −ν, −ν, 0, 0, 0) gives σ = (E, 0, 0, 0, 0, 0).
        let strain = [1.0, -0.3, -0.3, 0.0, 0.0, 0.0];
        let stress: Vec<f64> = (0..6)
            .map(|row| (0..6).map(|col| D[row][col] * strain[col]).sum())
            .collect();
        assert!((stress[0] - 2.0e11).abs() < 1e-4);
        assert!(stress[1].abs() < 1e-4 && stress[2].abs() < 1e-4);
    }
}

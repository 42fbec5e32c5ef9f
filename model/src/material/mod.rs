//! `material.isotropic`, `material.transversely_isotropic`, `material.orthotropic`: a material
//! by its engineering constants (SI), the parts of the mesh it fills, and for the anisotropic
//! ones the frame that orients it; `assemble` takes a list of them (its `materials` input).
//!
//! The laws, the conditions on the constants and the frames are in
//! [`crate::artifact::material`]. Each kind declares exactly the constants of its law, so a
//! study cannot give a constant that a law would ignore.

use crate::artifact::material::{ElasticLaw, EngineeringConstants, Frame, Material};
use crate::artifact::{Artifact, ArtifactType};
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError};

/// The one output of every material kind.
fn material_output() -> Vec<PortSpec> {
    vec![PortSpec::one(
        "material",
        ArtifactType::Material,
        "the material and the parts it fills: for `assemble`'s `materials`",
    )]
}

/// The checked material as the stage's output.
fn output(material: Material) -> Result<Outputs, StageError> {
    if material.parts.is_empty() {
        return Err(StageError::new(
            "`parts` is empty: name the mesh's parts made of this material",
        ));
    }
    material.check()?;
    Ok(Outputs::from([(
        "material".to_string(),
        Artifact::Material(Box::new(material)),
    )]))
}

/// An error for a frame vector given where the frame does not use it.
fn unused(name: &str, frame: &str) -> StageError {
    StageError::new(format!(
        "`{name}` is not used by the `{frame}` frame: remove it, or choose the frame that uses it"
    ))
}

pub struct Isotropic;

crate::stage_params! {
    /// The parameters of `material.isotropic`.
    pub struct IsotropicParams {
        /// the mesh's parts made of this material
        parts: Vec<String>,
        /// Young's modulus
        #[unit = "Pa"]
        #[min = 0.0]
        E: f64,
        /// Poisson's ratio
        nu: f64,
        /// density
        #[unit = "kg/m^3"]
        #[min = 0.0]
        rho: f64,
        /// Rayleigh mass-proportional damping (C = alpha M + beta K)
        #[unit = "1/s"]
        #[min = 0.0]
        alpha: f64 = 0.0,
        /// Rayleigh stiffness-proportional damping (C = alpha M + beta K)
        #[unit = "s"]
        #[min = 0.0]
        beta: f64 = 0.0,
    }
}

impl HasParams for Isotropic {
    type Params = IsotropicParams;
}

impl Stage for Isotropic {
    fn kind(&self) -> &'static str {
        "material.isotropic"
    }

    fn version(&self) -> u32 {
        1
    }

    fn doc(&self) -> &'static str {
        "An isotropic material (E, nu, density, Rayleigh damping) for the parts it names"
    }

    fn inputs(&self) -> Vec<PortSpec> {
        Vec::new()
    }

    fn outputs(&self) -> Vec<PortSpec> {
        material_output()
    }

    fn run(&self, params: &Params, _inputs: &Inputs) -> Result<Outputs, StageError> {
        let p = params.read::<Self>()?;
        output(Material {
            name: p.parts.join(", "),
            parts: p.parts,
            law: ElasticLaw::Isotropic {
                youngs_modulus: p.E,
                poisson_ratio: p.nu,
            },
            density: p.rho,
            alpha: p.alpha,
            beta: p.beta,
        })
    }
}

pub struct TransverselyIsotropic;

crate::stage_params! {
    /// The parameters of `material.transversely_isotropic`: isotropic in the plane normal to
    /// axis 3 (a friction lining's, axis 3 its thickness).
    pub struct TransverselyIsotropicParams {
        /// the mesh's parts made of this material
        parts: Vec<String>,
        /// Young's modulus in the plane (axes 1 and 2)
        #[unit = "Pa"]
        #[min = 0.0]
        E: f64,
        /// Poisson's ratio in the plane (nu_12)
        nu: f64,
        /// Young's modulus along axis 3
        #[unit = "Pa"]
        #[min = 0.0]
        E_3: f64,
        /// Poisson's ratio nu_13: the contraction along axis 3 under a stress in the plane
        nu_13: f64,
        /// shear modulus G_13 of the planes that hold axis 3
        #[unit = "Pa"]
        #[min = 0.0]
        G_13: f64,
        /// axis 3, [x, y, z]: the lining's normal (its length does not matter)
        normal: [f64; 3] = [0.0, 0.0, 1.0],
        /// density
        #[unit = "kg/m^3"]
        #[min = 0.0]
        rho: f64,
        /// Rayleigh mass-proportional damping (C = alpha M + beta K)
        #[unit = "1/s"]
        #[min = 0.0]
        alpha: f64 = 0.0,
        /// Rayleigh stiffness-proportional damping (C = alpha M + beta K)
        #[unit = "s"]
        #[min = 0.0]
        beta: f64 = 0.0,
    }
}

impl HasParams for TransverselyIsotropic {
    type Params = TransverselyIsotropicParams;
}

impl Stage for TransverselyIsotropic {
    fn kind(&self) -> &'static str {
        "material.transversely_isotropic"
    }

    fn version(&self) -> u32 {
        1
    }

    fn doc(&self) -> &'static str {
        "A transversely isotropic material (a friction lining: E, nu in its plane; E_3, nu_13, G_13 about its normal) for the parts it names"
    }

    fn inputs(&self) -> Vec<PortSpec> {
        Vec::new()
    }

    fn outputs(&self) -> Vec<PortSpec> {
        material_output()
    }

    fn run(&self, params: &Params, _inputs: &Inputs) -> Result<Outputs, StageError> {
        let p = params.read::<Self>()?;
        let constants =
            EngineeringConstants::transversely_isotropic((p.E, p.nu), p.E_3, p.nu_13, p.G_13);
        output(Material {
            name: p.parts.join(", "),
            parts: p.parts,
            law: ElasticLaw::Orthotropic {
                constants,
                frame: Frame::Normal { axis3: p.normal },
            },
            density: p.rho,
            alpha: p.alpha,
            beta: p.beta,
        })
    }
}

crate::choice! {
    /// How an orthotropic material's axes are oriented.
    pub enum FrameKind {
        /// Axes 1, 2, 3 along x, y, z.
        Global = "global",
        /// Axis 3 along `axis_3` through `origin`, axis 1 radial, axis 2 circumferential.
        Cylindrical = "cylindrical",
        /// Axis 3 along `axis_3`, axis 1 along `axis_1` (made orthogonal to axis 3).
        Axes = "axes",
    }
}

pub struct Orthotropic;

crate::stage_params! {
    /// The parameters of `material.orthotropic`.
    pub struct OrthotropicParams {
        /// the mesh's parts made of this material
        parts: Vec<String>,
        /// Young's modulus along axis 1
        #[unit = "Pa"]
        #[min = 0.0]
        E_1: f64,
        /// Young's modulus along axis 2
        #[unit = "Pa"]
        #[min = 0.0]
        E_2: f64,
        /// Young's modulus along axis 3
        #[unit = "Pa"]
        #[min = 0.0]
        E_3: f64,
        /// Poisson's ratio nu_12: the contraction along axis 2 under a stress along axis 1
        nu_12: f64,
        /// Poisson's ratio nu_13: the contraction along axis 3 under a stress along axis 1
        nu_13: f64,
        /// Poisson's ratio nu_23: the contraction along axis 3 under a stress along axis 2
        nu_23: f64,
        /// shear modulus in the 1-2 plane
        #[unit = "Pa"]
        #[min = 0.0]
        G_12: f64,
        /// shear modulus in the 1-3 plane
        #[unit = "Pa"]
        #[min = 0.0]
        G_13: f64,
        /// shear modulus in the 2-3 plane
        #[unit = "Pa"]
        #[min = 0.0]
        G_23: f64,
        /// how the axes are oriented
        frame: FrameKind = FrameKind::Global,
        /// a point of the cylindrical frame's axis, [x, y, z] in m
        origin: [f64; 3] = [0.0, 0.0, 0.0],
        /// axis 3 (cylindrical: the axis; axes: axis 3), [x, y, z]
        axis_3: [f64; 3] = [0.0, 0.0, 1.0],
        /// axis 1 of the `axes` frame, [x, y, z]
        axis_1: [f64; 3] = [1.0, 0.0, 0.0],
        /// density
        #[unit = "kg/m^3"]
        #[min = 0.0]
        rho: f64,
        /// Rayleigh mass-proportional damping (C = alpha M + beta K)
        #[unit = "1/s"]
        #[min = 0.0]
        alpha: f64 = 0.0,
        /// Rayleigh stiffness-proportional damping (C = alpha M + beta K)
        #[unit = "s"]
        #[min = 0.0]
        beta: f64 = 0.0,
    }
}

impl OrthotropicParams {
    /// The frame, refusing a vector the chosen frame would ignore.
    fn frame(&self) -> Result<Frame, StageError> {
        let given = [
            ("origin", self.origin != [0.0, 0.0, 0.0]),
            ("axis_3", self.axis_3 != [0.0, 0.0, 1.0]),
            ("axis_1", self.axis_1 != [1.0, 0.0, 0.0]),
        ];
        let uses: &[&str] = match self.frame {
            FrameKind::Global => &[],
            FrameKind::Cylindrical => &["origin", "axis_3"],
            FrameKind::Axes => &["axis_3", "axis_1"],
        };
        if let Some((name, _)) = given
            .iter()
            .find(|(name, changed)| *changed && !uses.contains(name))
        {
            return Err(unused(name, self.frame.name()));
        }
        Ok(match self.frame {
            FrameKind::Global => Frame::Global,
            FrameKind::Cylindrical => Frame::Cylindrical {
                origin: self.origin,
                axis: self.axis_3,
            },
            FrameKind::Axes => Frame::Axes {
                axis1: self.axis_1,
                axis3: self.axis_3,
            },
        })
    }
}

impl HasParams for Orthotropic {
    type Params = OrthotropicParams;
}

impl Stage for Orthotropic {
    fn kind(&self) -> &'static str {
        "material.orthotropic"
    }

    fn version(&self) -> u32 {
        1
    }

    fn doc(&self) -> &'static str {
        "An orthotropic material (nine engineering constants in a global, cylindrical or given frame) for the parts it names"
    }

    fn inputs(&self) -> Vec<PortSpec> {
        Vec::new()
    }

    fn outputs(&self) -> Vec<PortSpec> {
        material_output()
    }

    fn run(&self, params: &Params, _inputs: &Inputs) -> Result<Outputs, StageError> {
        let p = params.read::<Self>()?;
        let constants = EngineeringConstants {
            youngs_moduli: [p.E_1, p.E_2, p.E_3],
            poisson_ratios: [p.nu_12, p.nu_13, p.nu_23],
            shear_moduli: [p.G_12, p.G_13, p.G_23],
        };
        let frame = p.frame()?;
        output(Material {
            name: p.parts.join(", "),
            parts: p.parts,
            law: ElasticLaw::Orthotropic { constants, frame },
            density: p.rho,
            alpha: p.alpha,
            beta: p.beta,
        })
    }
}

#[cfg(test)]
mod tests;

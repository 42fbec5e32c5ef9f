//! `vtu.mesh` and `vtu.modes`: a mesh, and real mode shapes on it, as VTK XML unstructured
//! grids (`.vtu`, written by [`crate::vtu_writer`]) for ParaView (`File > Open`), PyVista
//! (`pyvista.read`) or meshio.

use crate::artifact::{Artifact, ArtifactType};
use crate::artifact::{Mesh, Model, RealModes};
use crate::params::{HasParams, NoParams};
use crate::stage::{Inputs, Outputs, Params, PortSpec, Stage, StageError};
use crate::vtu_writer::{mesh_vtu, modes_vtu};

/// `vtu.mesh`: the mesh with its parts, node sets and contact pairs.
pub struct MeshVtu;

impl HasParams for MeshVtu {
    type Params = NoParams;
}

impl Stage for MeshVtu {
    fn kind(&self) -> &'static str {
        "vtu.mesh"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Write the mesh as a VTU file for ParaView: parts, node sets, contact pairs"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "mesh",
            ArtifactType::Mesh,
            "the mesh to look at",
        )]
    }
    fn renamed_outputs(&self) -> &'static [(&'static str, &'static str)] {
        &[("vtu", "mesh")]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "mesh",
            ArtifactType::Document,
            "mesh.vtu: cell data `part`, point data per node set and `contact`",
        )]
    }
    fn run(&self, _params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let mesh = inputs.get::<Mesh>("mesh")?;
        let text = mesh_vtu(mesh).map_err(StageError::new)?;
        Ok(Outputs::from([(
            "mesh".to_string(),
            Artifact::document("vtu", text),
        )]))
    }
}

/// `vtu.modes`: the model's mesh with one displacement array per real mode.
pub struct ModesVtu;

crate::stage_params! {
    /// The parameters of `vtu.modes`.
    pub struct ModesVtuParams {
        /// write at most this many modes, lowest first
        #[min = 1]
        max_modes: usize = 20,
    }
}

impl HasParams for ModesVtu {
    type Params = ModesVtuParams;
}

impl Stage for ModesVtu {
    fn kind(&self) -> &'static str {
        "vtu.modes"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Write real mode shapes as a VTU file for ParaView: one point vector array per mode"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "model",
                ArtifactType::Model,
                "the model: mesh and node-to-DOF map",
            ),
            PortSpec::one(
                "modes",
                ArtifactType::RealModes,
                "real modes over the model's free DOFs",
            ),
        ]
    }
    fn renamed_outputs(&self) -> &'static [(&'static str, &'static str)] {
        &[("vtu", "modes")]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "modes",
            ArtifactType::Document,
            "modes.vtu: point data `mode_0001_<f>Hz`, ... (vectors, zero at clamped DOFs)",
        )]
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let model = inputs.get::<Model>("model")?;
        let modes = inputs.get::<RealModes>("modes")?;
        let ModesVtuParams { max_modes } = params.read::<Self>()?;
        let text = modes_vtu(model, modes, max_modes)?;
        Ok(Outputs::from([(
            "modes".to_string(),
            Artifact::document("vtu", text),
        )]))
    }
}

//! `assemble`: the finite-element model of a mesh of solid elements — mass `M`, stiffness `K`
//! and Rayleigh damping `C` over the free degrees of freedom.
//!
//! Linear elasticity, small strains. With `N` the shape functions, `u ≈ N q`:
//!
//! ```text
//! M = Σ_e ∫_e ρ Nᵀ N dV          (consistent mass)
//! K = Σ_e K_e                     (elements of any kind, see [`element`])
//! C = Σ_parts (α_p M_p + β_p K_p) (Rayleigh damping per part, [`material`])
//! ```
//!
//! Each part of the mesh names its material: `disc` or `pad` (the paper's Table 1 are the
//! defaults). The DOFs of the node sets listed in `clamped` are removed (`u = 0` there); the
//! others are numbered node by node ([`dofs`]). Element matrices are computed in parallel and
//! summed in a fixed order ([`sparse`]): the matrices are bit-identical from run to run.

pub mod dofs;
pub mod sparse;

#[cfg(test)]
mod tests;

use rayon::prelude::*;

use crate::artifact::Model;
use crate::artifact::mesh::Mesh;
use crate::artifact::{Artifact, ArtifactType};
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError, Value};
use crate::table::Table;

use crate::artifact::ElementKind;
use crate::fem::element::{self, Degenerate, ElementMatrices};
use crate::fem::material::{MATERIAL_PARTS, Material};

/// How many offending elements an error message names.
const ELEMENTS_NAMED_IN_ERRORS: usize = 5;

/// `assemble`: mesh → model (`M`, `K`, `C`) and a summary table.
pub struct Assemble;

crate::stage_params! {
    /// The parameters of `assemble`: the materials of the parts `disc` and `pad` (the paper's
    /// Table 1 by default) and the clamped node sets.
    pub struct AssembleParams {
        /// Young's modulus of the disc
        #[unit = "Pa"]
        #[min = 0.0]
        E_disc: f64 = 2.02e11,
        /// Poisson's ratio of the disc
        nu_disc: f64 = 0.29,
        /// density of the disc
        #[unit = "kg/m^3"]
        #[min = 0.0]
        rho_disc: f64 = 7850.0,
        /// Rayleigh mass-proportional damping of the disc (C = alpha M + beta K)
        #[unit = "1/s"]
        #[min = 0.0]
        alpha_disc: f64 = 3.75,
        /// Rayleigh stiffness-proportional damping of the disc (C = alpha M + beta K)
        #[unit = "s"]
        #[min = 0.0]
        beta_disc: f64 = 5e-8,
        /// Young's modulus of the pads
        #[unit = "Pa"]
        #[min = 0.0]
        E_pad: f64 = 3e8,
        /// Poisson's ratio of the pads
        nu_pad: f64 = 0.3,
        /// density of the pads
        #[unit = "kg/m^3"]
        #[min = 0.0]
        rho_pad: f64 = 5102.0,
        /// Rayleigh mass-proportional damping of the pads (C = alpha M + beta K)
        #[unit = "1/s"]
        #[min = 0.0]
        alpha_pad: f64 = 54.375,
        /// Rayleigh stiffness-proportional damping of the pads (C = alpha M + beta K)
        #[unit = "s"]
        #[min = 0.0]
        beta_pad: f64 = 72.5e-8,
        /// node sets whose DOFs are fixed (`set:xy` fixes only those axes); empty for a free body
        clamped: Vec<String> = vec!["hub".into(), "pad_backs".into()],
    }
}

impl AssembleParams {
    /// The material of part `part`: `disc` or `pad` ([`MATERIAL_PARTS`]).
    pub fn material(&self, part: &str) -> Result<Material, StageError> {
        let material = match part {
            "disc" => Material {
                youngs_modulus: self.E_disc,
                poisson_ratio: self.nu_disc,
                density: self.rho_disc,
                alpha: self.alpha_disc,
                beta: self.beta_disc,
            },
            "pad" => Material {
                youngs_modulus: self.E_pad,
                poisson_ratio: self.nu_pad,
                density: self.rho_pad,
                alpha: self.alpha_pad,
                beta: self.beta_pad,
            },
            other => {
                return Err(StageError::new(format!(
                    "part `{other}` has no material: parts must be named {}",
                    MATERIAL_PARTS.join(" or ")
                )));
            }
        };
        material.check(part)?;
        Ok(material)
    }
}

impl HasParams for Assemble {
    type Params = AssembleParams;
}

impl Stage for Assemble {
    fn kind(&self) -> &'static str {
        "assemble"
    }

    fn version(&self) -> u32 {
        1
    }

    fn doc(&self) -> &'static str {
        "Assemble mass, stiffness and Rayleigh damping of a mesh of solid elements (hexahedra, tetrahedra, wedges), clamping node sets"
    }

    fn inputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "mesh",
            ArtifactType::Mesh,
            "mesh of solid elements with parts `disc` and `pad`",
        )]
    }

    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one("model", ArtifactType::Model, "M, K, C over the free DOFs"),
            PortSpec::one(
                "summary",
                ArtifactType::Table,
                "per part (and `total`): elements, free DOFs, volume, mass",
            ),
        ]
    }

    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let mesh: &Mesh = inputs.get("mesh")?;
        let params = params.read::<Self>()?;
        let (model, summary) = assemble_model(mesh, &params)?;
        Ok(Outputs::from([
            ("model".to_string(), Artifact::Model(Box::new(model))),
            ("summary".to_string(), Artifact::Table(summary)),
        ]))
    }
}

/// Checks the mesh's indices and coordinates so that assembly cannot index out of bounds.
fn check_mesh(mesh: &Mesh) -> Result<(), StageError> {
    if mesh.elements.is_empty() {
        return Err(StageError::new("the mesh has no elements"));
    }
    mesh.elements
        .check(mesh.n_nodes(), mesh.parts.len())
        .map_err(StageError::new)?;
    if let Some(node) = mesh
        .nodes
        .iter()
        .position(|x| x.iter().any(|coordinate| !coordinate.is_finite()))
    {
        return Err(StageError::new(format!(
            "node {node} has a non-finite coordinate {:?}",
            mesh.nodes[node]
        )));
    }
    Ok(())
}

/// The material of every part, by part index.
fn part_materials(mesh: &Mesh, params: &AssembleParams) -> Result<Vec<Material>, StageError> {
    mesh.parts
        .iter()
        .map(|part| params.material(part))
        .collect()
}

fn degenerate_error(failures: &[(usize, Degenerate)]) -> StageError {
    let named: Vec<String> = failures
        .iter()
        .take(ELEMENTS_NAMED_IN_ERRORS)
        .map(|(element, failure)| {
            format!(
                "element {element} (det J = {:.3e} at {})",
                failure.det_j, failure.location
            )
        })
        .collect();
    StageError::new(format!(
        "{} inverted or degenerate element(s) (det J <= 0): {}{}",
        failures.len(),
        named.join(", "),
        if failures.len() > ELEMENTS_NAMED_IN_ERRORS {
            ", ..."
        } else {
            ""
        }
    ))
}

/// Linear tetrahedra have constant strain and lock in bending: a coarse mesh of them gives
/// frequencies far too high. They are accepted, with a warning.
fn warn_of_linear_tetrahedra(mesh: &Mesh) {
    let n_tet4 = mesh
        .elements
        .iter()
        .filter(|element| element.kind == ElementKind::Tet4)
        .count();
    if n_tet4 > 0 {
        tracing::warn!(
            "{n_tet4} of {} elements are 4-node tetrahedra: constant strain, stiff in bending \
             (mesh with 10-node tetrahedra for frequencies that converge)",
            mesh.elements.len()
        );
    }
}

/// The model of `mesh` with the node sets `params.clamped` fixed, and its summary table.
pub fn assemble_model(mesh: &Mesh, params: &AssembleParams) -> Result<(Model, Table), StageError> {
    check_mesh(mesh)?;
    let materials = part_materials(mesh, params)?;
    let (dof_of_node, n_dofs) = dofs::number_dofs(mesh, &params.clamped)?;
    if n_dofs == 0 {
        return Err(StageError::new(
            "every node is clamped: the model has no free DOF",
        ));
    }
    let elasticities: Vec<[[f64; 6]; 6]> = materials.iter().map(Material::elasticity).collect();

    warn_of_linear_tetrahedra(mesh);
    let results: Vec<Result<ElementMatrices, Degenerate>> = (0..mesh.elements.len())
        .into_par_iter()
        .map(|element| {
            let element = mesh.elements.get(element);
            let coords: Vec<[f64; 3]> = element
                .nodes
                .iter()
                .map(|&node| mesh.nodes[node as usize])
                .collect();
            let part = element.part as usize;
            element::element_matrices(
                element.kind,
                &coords,
                &elasticities[part],
                materials[part].density,
            )
        })
        .collect();
    let failures: Vec<(usize, Degenerate)> = results
        .iter()
        .enumerate()
        .filter_map(|(element, result)| result.as_ref().err().map(|failure| (element, *failure)))
        .collect();
    if !failures.is_empty() {
        return Err(degenerate_error(&failures));
    }
    let elements: Vec<ElementMatrices> = results.into_iter().flatten().collect();
    let damping: Vec<(f64, f64)> = mesh
        .elements
        .parts()
        .iter()
        .map(|&part| {
            (
                materials[part as usize].alpha,
                materials[part as usize].beta,
            )
        })
        .collect();

    let assembled = sparse::assemble(mesh, &dof_of_node, n_dofs, &elements, &damping);
    let summary = summary_table(mesh, &materials, &dof_of_node, &elements, n_dofs);
    let model = Model {
        mesh: mesh.clone(),
        dof_of_node: dof_of_node.clone(),
        M: assembled.M,
        K: assembled.K,
        C: assembled.C,
    };
    Ok((model, summary))
}

/// One row per part and a `total` row: elements, free DOFs, volume, mass.
fn summary_table(
    mesh: &Mesh,
    materials: &[Material],
    dof_of_node: &[[Option<u32>; 3]],
    elements: &[ElementMatrices],
    n_dofs: usize,
) -> Table {
    let n_parts = mesh.parts.len();
    let mut n_elements = vec![0i64; n_parts];
    let mut volume = vec![0.0; n_parts];
    let mut node_in_part = vec![vec![false; mesh.n_nodes()]; n_parts];
    for (element, matrices) in mesh.elements.iter().zip(elements) {
        let part = element.part as usize;
        n_elements[part] += 1;
        volume[part] += matrices.volume;
        for &node in element.nodes {
            node_in_part[part][node as usize] = true;
        }
    }
    let free_dofs_of = |in_part: &Vec<bool>| -> i64 {
        in_part
            .iter()
            .zip(dof_of_node)
            .filter(|(inside, _)| **inside)
            .map(|(_, dofs)| dofs.iter().flatten().count() as i64)
            .sum()
    };
    let mut names: Vec<String> = mesh.parts.clone();
    let mut dofs: Vec<i64> = node_in_part.iter().map(free_dofs_of).collect();
    let mut masses: Vec<f64> = volume
        .iter()
        .zip(materials)
        .map(|(volume, material)| volume * material.density)
        .collect();
    names.push("total".into());
    n_elements.push(mesh.elements.len() as i64);
    dofs.push(n_dofs as i64);
    volume.push(volume.iter().sum());
    masses.push(masses.iter().sum());
    Table::new()
        .with("part", names)
        .with("n_elements", n_elements)
        .with("n_dofs", dofs)
        .with("volume_m3", volume)
        .with("mass_kg", masses)
}

/// `assemble` with default materials (some overridden by name) and the node sets of
/// `clamped` (comma-separated): the model of a verification case or a benchmark.
pub fn with_default_materials(
    mesh: &Mesh,
    clamped: &str,
    overrides: &[(&str, f64)],
) -> Result<(Model, AssembleParams), StageError> {
    let mut values: Vec<(&str, Value)> = overrides
        .iter()
        .map(|&(name, value)| (name, Value::Float(value)))
        .collect();
    values.push(("clamped", Value::Str(clamped.to_string())));
    let params = Params::defaults(&Assemble, &values).read::<Assemble>()?;
    Ok((assemble_model(mesh, &params)?.0, params))
}

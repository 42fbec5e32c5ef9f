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
//! Every part of the mesh has one material ([`crate::artifact::material`]): those of the
//! `materials` input (`material.*` stages, each naming its parts), or, when none is connected,
//! the short form for a mesh of the two parts `disc` and `pad`, whose constants are this
//! stage's `*_disc` and `*_pad` parameters (the paper's Table 1 by default). An element whose
//! material axes vary in space (a cylindrical frame) takes them at its centre. The DOFs of the
//! node sets listed in `clamped` are removed (`u = 0` there); the others are numbered node by
//! node ([`dofs`]). Element matrices are computed in parallel and summed in a fixed order
//! ([`sparse`]): the matrices are bit-identical from run to run.
//!
//! Parts meshed apart are joined by `ties`, each `slave_set -> master_set`: every node of the
//! slave set follows the master set's surface, u_s = Σ_l w_sl u_l, and its DOFs are
//! eliminated, `K_red = Tᵀ K T` (likewise `M`, `C`), exactly ([`ties`]). The weights are the
//! master face's shape functions where the node projects (`tie_method: collocation`, the
//! default), or the dual mortar rows (`mortar`, which passes the patch test on non-matching
//! meshes). The model records the tied nodes ([`Model::tied`]) so that every output shows
//! them moving with their masters, and its contact pairs read a tied node's masters in its
//! stead. Without ties the model is the one assembled before ties existed, bit for bit.

pub mod dofs;
pub mod sparse;
pub mod ties;

#[cfg(test)]
mod tests;

use rayon::prelude::*;

use crate::artifact::Model;
use crate::artifact::mesh::Mesh;
use crate::artifact::{Artifact, ArtifactType};
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError, Value};
use crate::table::Table;

use crate::artifact::ElementKind;
use crate::artifact::material::{ElasticLaw, Elasticity, Material};
use crate::fem::element::{self, Degenerate, ElementMatrices, element_elasticity};
pub use ties::TieMethod;

/// The parts of the short form, whose materials are this stage's parameters.
pub const SHORT_FORM_PARTS: [&str; 2] = ["disc", "pad"];

/// How many offending elements an error message names.
const ELEMENTS_NAMED_IN_ERRORS: usize = 5;

/// `assemble`: mesh → model (`M`, `K`, `C`) and a summary table.
pub struct Assemble;

crate::stage_params! {
    /// The parameters of `assemble`: the clamped node sets, the tied parts, and the short
    /// form's materials of the parts `disc` and `pad` (the paper's Table 1 by default), used
    /// when no `materials` are connected.
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
        /// tied parts, each `slave_set -> master_set`: every node of the slave set follows the
        /// master set's surface where it projects (u = Σ N_l(ξ*) u_l), its DOFs eliminated;
        /// empty for none
        ties: Vec<String> = vec![],
        /// the largest distance from a slave node of a tie to its master surface
        #[unit = "m"]
        #[min = 0.0]
        tie_distance: f64 = 1e-4,
        /// how ties hold their slave nodes: `collocation` (each at its closest point of the
        /// master surface) or `mortar` (the dual mortar rows: constant stress passes
        /// non-matching meshes exactly)
        tie_method: TieMethod = TieMethod::Mortar,
    }
}

impl AssembleParams {
    /// The clamps and ties of these parameters.
    pub fn constraints(&self) -> Constraints<'_> {
        Constraints {
            clamped: &self.clamped,
            ties: &self.ties,
            tie_distance: self.tie_distance,
            tie_method: self.tie_method,
        }
    }

    /// The short form's material of part `part`: `disc` or `pad` ([`SHORT_FORM_PARTS`]).
    pub fn material(&self, part: &str) -> Result<Material, StageError> {
        let (E, nu, rho, alpha, beta) = match part {
            "disc" => (
                self.E_disc,
                self.nu_disc,
                self.rho_disc,
                self.alpha_disc,
                self.beta_disc,
            ),
            "pad" => (
                self.E_pad,
                self.nu_pad,
                self.rho_pad,
                self.alpha_pad,
                self.beta_pad,
            ),
            other => {
                return Err(StageError::new(format!(
                    "part `{other}` has no material: without `materials` (a list of \
                     `material.*` stages), the parts must be named {}",
                    SHORT_FORM_PARTS.join(" or ")
                )));
            }
        };
        let material = Material {
            name: part.to_string(),
            parts: vec![part.to_string()],
            law: ElasticLaw::Isotropic {
                youngs_modulus: E,
                poisson_ratio: nu,
            },
            density: rho,
            alpha,
            beta,
        };
        material.check().map_err(|err| {
            StageError::new(format!(
                "{} (the short form's `*_{part}` parameters)",
                err.message
            ))
        })?;
        Ok(material)
    }

    /// The first short-form parameter set away from its default, by name.
    fn short_form_given(&self) -> Result<Option<&'static str>, StageError> {
        let defaults = Params::defaults(&Assemble, &[]).read::<Assemble>()?;
        let pairs = [
            ("E_disc", self.E_disc, defaults.E_disc),
            ("nu_disc", self.nu_disc, defaults.nu_disc),
            ("rho_disc", self.rho_disc, defaults.rho_disc),
            ("alpha_disc", self.alpha_disc, defaults.alpha_disc),
            ("beta_disc", self.beta_disc, defaults.beta_disc),
            ("E_pad", self.E_pad, defaults.E_pad),
            ("nu_pad", self.nu_pad, defaults.nu_pad),
            ("rho_pad", self.rho_pad, defaults.rho_pad),
            ("alpha_pad", self.alpha_pad, defaults.alpha_pad),
            ("beta_pad", self.beta_pad, defaults.beta_pad),
        ];
        Ok(pairs
            .into_iter()
            .find(|(_, value, default)| value != default)
            .map(|(name, _, _)| name))
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
        "Assemble mass, stiffness and Rayleigh damping of a mesh of solid elements (hexahedra, tetrahedra, wedges), clamping node sets and tying parts meshed apart"
    }

    fn inputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one("mesh", ArtifactType::Mesh, "mesh of solid elements"),
            PortSpec::list(
                "materials",
                ArtifactType::Material,
                "one material for each part of the mesh; without, the short form: parts `disc` \
                 and `pad`, their constants this stage's parameters",
            )
            .optional(),
        ]
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
        let materials = part_materials(mesh, &params, &inputs.get_list("materials")?)?;
        let (model, summary) = assemble_constrained(mesh, &params.constraints(), &materials)?;
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
    for (index, pair) in mesh.contact_pairs.iter().enumerate() {
        pair.check(mesh.n_nodes())
            .map_err(|reason| StageError::new(format!("contact pair {index}: {reason}")))?;
    }
    Ok(())
}

/// The material of every part of the mesh, by part index: one of `declared` (the `materials`
/// input) for each, or the short form's when none is declared.
fn part_materials(
    mesh: &Mesh,
    params: &AssembleParams,
    declared: &[&Material],
) -> Result<Vec<Material>, StageError> {
    if declared.is_empty() {
        return mesh
            .parts
            .iter()
            .map(|part| params.material(part))
            .collect();
    }
    if let Some(name) = params.short_form_given()? {
        return Err(StageError::new(format!(
            "`{name}` is the short form for meshes of parts `disc` and `pad`: with `materials` \
             connected, give every constant in the materials"
        )));
    }
    let mut owner: Vec<Option<&Material>> = vec![None; mesh.parts.len()];
    for &material in declared {
        for part in &material.parts {
            let Some(index) = mesh.parts.iter().position(|name| name == part) else {
                return Err(StageError::new(format!(
                    "material `{}` names part `{part}`, which the mesh does not have (its parts: {})",
                    material.name,
                    mesh.parts.join(", ")
                )));
            };
            if let Some(other) = owner[index] {
                return Err(StageError::new(format!(
                    "part `{part}` is named by two materials, `{}` and `{}`",
                    other.name, material.name
                )));
            }
            owner[index] = Some(material);
        }
    }
    mesh.parts
        .iter()
        .zip(owner)
        .map(|(part, owner)| {
            owner.cloned().ok_or_else(|| {
                let names: Vec<String> = declared
                    .iter()
                    .map(|material| format!("`{}`", material.name))
                    .collect();
                StageError::new(format!(
                    "part `{part}` of the mesh has no material (the materials name {})",
                    names.join(", ")
                ))
            })
        })
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

/// The model of `mesh` with the short form's materials, the node sets `params.clamped` fixed
/// and the parts of `params.ties` tied, and its summary table.
pub fn assemble_model(mesh: &Mesh, params: &AssembleParams) -> Result<(Model, Table), StageError> {
    let materials = part_materials(mesh, params, &[])?;
    assemble_constrained(mesh, &params.constraints(), &materials)
}

/// The model of `mesh` with `materials` by part index and the node sets `clamped` fixed, and
/// its summary table.
pub fn assemble_with(
    mesh: &Mesh,
    clamped: &[String],
    materials: &[Material],
) -> Result<(Model, Table), StageError> {
    let constraints = Constraints {
        clamped,
        ties: &[],
        tie_distance: 0.0,
        tie_method: TieMethod::Collocation,
    };
    assemble_constrained(mesh, &constraints, materials)
}

/// What holds a model: the clamped node sets and the ties (as `assemble`'s parameters of the
/// same names).
#[derive(Debug, Clone, Copy)]
pub struct Constraints<'a> {
    /// `set` or `set:axes`, as [`dofs::clamped_axes`] reads them.
    pub clamped: &'a [String],
    /// `slave_set -> master_set`, as [`ties::tie_nodes`] reads them.
    pub ties: &'a [String],
    /// The largest distance (m) from a slave node to its master surface.
    pub tie_distance: f64,
    /// How the ties hold their slave nodes.
    pub tie_method: TieMethod,
}

/// The model of `mesh` with `materials` by part index, held by `constraints`, and its summary
/// table.
pub fn assemble_constrained(
    mesh: &Mesh,
    constraints: &Constraints,
    materials: &[Material],
) -> Result<(Model, Table), StageError> {
    check_mesh(mesh)?;
    let clamped = dofs::clamped_axes(mesh, constraints.clamped)?;
    let tied = ties::tie_nodes(
        mesh,
        constraints.ties,
        constraints.tie_distance,
        constraints.tie_method,
    )?;
    tied.refuse_clamped(mesh, &clamped, constraints.clamped)?;
    let mut contact_pairs = None;
    if !tied.nodes.is_empty() {
        let mut pairs = mesh.contact_pairs.clone();
        tied.substitute_pairs(&mut pairs)?;
        contact_pairs = Some(pairs);
    }
    let (dof_of_node, n_dofs) = dofs::number_free(mesh, &clamped, &tied.is_tied(mesh.n_nodes()))?;
    if n_dofs == 0 {
        return Err(StageError::new(
            "every node is clamped: the model has no free DOF",
        ));
    }
    // A material whose axes do not vary has one elasticity for all its elements.
    let uniform: Vec<Option<Elasticity>> = materials
        .iter()
        .map(|material| {
            material
                .is_uniform()
                .then(|| material.elasticity_at([0.0; 3]))
                .transpose()
        })
        .collect::<Result<_, _>>()?;

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
            let D = match uniform[part] {
                Some(D) => D,
                None => element_elasticity(&materials[part], element.kind, &coords)?,
            };
            Ok(element::element_matrices(
                element.kind,
                &coords,
                &D,
                materials[part].density,
            ))
        })
        .collect::<Result<_, StageError>>()?;
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

    let substitution = sparse::Substitution::new(mesh.n_nodes(), &tied.nodes);
    let assembled = sparse::assemble(
        mesh,
        &dof_of_node,
        n_dofs,
        &substitution,
        &elements,
        &damping,
    );
    let summary = summary_table(mesh, materials, &dof_of_node, &elements, n_dofs);
    let mut model = Model {
        mesh: mesh.clone(),
        dof_of_node: dof_of_node.clone(),
        M: assembled.M,
        K: assembled.K,
        C: assembled.C,
        tied: tied.nodes,
    };
    if let Some(pairs) = contact_pairs {
        model.mesh.contact_pairs = pairs;
    }
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

//! `mesh.cad`: a brake from its CAD, meshed by Gmsh from a `.geo` script kept beside the study.
//!
//! The stage runs the Gmsh program on the script with the study's numbers
//! (`gmsh script.geo -3 -order o -clmax h -setnumber name value ... -nt 1 -format msh41`), and
//! reads the mesh as `mesh.gmsh` does ([`super::gmsh`]): physical volumes become parts,
//! physical surfaces, curves and points node sets (faces to clamp, load, pair by mortar or
//! tie), and a conforming interface may be paired node to node.
//!
//! The script declares the numbers a study may set with `DefineConstant`
//! (`DefineConstant[ vanes = 36, thickness = 0.028 ];`); `mesh_size` is always set, to the
//! largest element size, so a script can grade its own sizes from it. `set` takes
//! `name=value` items; Gmsh ignores a name the script does not define, so the stage refuses
//! one that the script's text does not mention.
//!
//! The cache key holds the script's bytes and Gmsh's version beside the parameters
//! ([`Stage::external_inputs`]): an edited script or another Gmsh reruns the stage, a sweep
//! over a set number caches like any other (a file the script `Include`s is not followed).
//! Gmsh meshes on one thread, where its output is the same bytes for the same input.
//!
//! The program is `gmsh` on the `PATH`, or `SQUEAL_GMSH`. Without it the error says how to
//! install it (`python3 -m pip install gmsh`, or Debian's `gmsh`).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use super::gmsh::{MshReading, read_msh_bytes};
use crate::artifact::{Artifact, ArtifactType};
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError};
use crate::table::Table;

pub struct MeshCad;

crate::stage_params! {
    /// The parameters of `mesh.cad`.
    pub struct CadParams {
        ..reading: MshReading,
        /// the Gmsh geometry script, .geo (relative to the study's folder)
        script: PathBuf,
        /// numbers the script declares with DefineConstant, set for this run: name=value items
        set: Vec<String> = Vec::new(),
        /// largest element size (Gmsh's -clmax; also the script's number mesh_size)
        #[unit = "m"]
        #[min = 0.0]
        mesh_size: f64,
        /// element order: 1 (4-node tetrahedra) or 2 (10-node tetrahedra)
        #[min = 1]
        order: usize = 2,
    }
}

impl HasParams for MeshCad {
    type Params = CadParams;
}

/// The Gmsh program to run.
fn program() -> PathBuf {
    std::env::var_os("SQUEAL_GMSH").map_or_else(|| PathBuf::from("gmsh"), PathBuf::from)
}

/// Why `program` could not be started, and how to install Gmsh.
fn cannot_run(program: &Path, err: std::io::Error) -> String {
    format!(
        "cannot run Gmsh (`{}`: {err}): install it with `python3 -m pip install gmsh` (or Debian's `apt-get install gmsh`), or name it in SQUEAL_GMSH",
        program.display()
    )
}

/// The version `program --version` prints; the error says how to install Gmsh.
fn version_of(program: &Path) -> Result<String, String> {
    let output = Command::new(program)
        .arg("--version")
        .output()
        .map_err(|err| cannot_run(program, err))?;
    // Gmsh prints its version on stderr or stdout, depending on the build.
    let text = [output.stdout, output.stderr]
        .iter()
        .map(|bytes| String::from_utf8_lossy(bytes).trim().to_string())
        .find(|text| !text.is_empty())
        .unwrap_or_default();
    if output.status.success() && !text.is_empty() {
        Ok(text)
    } else {
        Err(format!(
            "`{} --version` failed ({}): is it Gmsh?",
            program.display(),
            output.status
        ))
    }
}

/// Gmsh's version, asked once per process.
fn gmsh_version() -> Result<String, StageError> {
    static VERSION: OnceLock<Result<String, String>> = OnceLock::new();
    VERSION
        .get_or_init(|| version_of(&program()))
        .clone()
        .map_err(StageError::new)
}

/// The `name=value` items of `set`, checked against the script's text.
fn numbers(set: &[String], script: &str) -> Result<Vec<(String, f64)>, StageError> {
    set.iter()
        .map(|item| {
            let Some((name, value)) = item.split_once('=') else {
                return Err(StageError::new(format!(
                    "set: `{item}` is not name=value"
                )));
            };
            let (name, value) = (name.trim(), value.trim());
            let value: f64 = value.parse().ok().filter(|value: &f64| value.is_finite()).ok_or_else(|| {
                StageError::new(format!("set: `{item}`: `{value}` is not a number"))
            })?;
            let valid = !name.is_empty()
                && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
            if !valid {
                return Err(StageError::new(format!(
                    "set: `{item}`: `{name}` is not a Gmsh variable name"
                )));
            }
            if !script.contains(name) {
                return Err(StageError::new(format!(
                    "set: `{name}` does not appear in the script: Gmsh would ignore it (declare it with DefineConstant)"
                )));
            }
            Ok((name.to_string(), value))
        })
        .collect()
}

/// Gmsh's lines that report errors, from its output.
fn error_lines(output: &std::process::Output) -> Vec<String> {
    [&output.stdout, &output.stderr]
        .iter()
        .flat_map(|bytes| {
            String::from_utf8_lossy(bytes)
                .lines()
                .filter(|line| line.starts_with("Error"))
                .map(|line| line.trim().to_string())
                .collect::<Vec<_>>()
        })
        .collect()
}

/// Meshes `script` with Gmsh into `out`.
fn mesh_script(
    script: &Path,
    params: &CadParams,
    numbers: &[(String, f64)],
    out: &Path,
) -> Result<(), StageError> {
    let program = program();
    let size = params.mesh_size.to_string();
    let mut command = Command::new(&program);
    command
        .arg(script)
        .args(["-3", "-order", &params.order.to_string(), "-clmax", &size])
        .args(["-nt", "1", "-format", "msh41", "-v", "2"])
        .args(["-setnumber", "mesh_size", &size]);
    for (name, value) in numbers {
        command.args(["-setnumber", name, &value.to_string()]);
    }
    let output = command
        .arg("-o")
        .arg(out)
        .output()
        .map_err(|err| StageError::new(cannot_run(&program, err)))?;
    let errors = error_lines(&output);
    if !output.status.success() || !errors.is_empty() || !out.exists() {
        let reason = if errors.is_empty() {
            format!("it exited with {} and wrote no mesh", output.status)
        } else {
            errors.join("; ")
        };
        return Err(StageError::new(format!(
            "{}: Gmsh failed: {reason}",
            script.display()
        )));
    }
    Ok(())
}

impl Stage for MeshCad {
    fn kind(&self) -> &'static str {
        "mesh.cad"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Mesh a CAD geometry with Gmsh from a .geo script and the study's numbers: parts, node sets and contact pairs from its physical groups"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        Vec::new()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "mesh",
                ArtifactType::Mesh,
                "solid elements, parts, node sets and contact pairs",
            ),
            PortSpec::one(
                "summary",
                ArtifactType::Table,
                "nodes, elements, dofs (three per node, before clamps)",
            ),
        ]
    }
    fn external_inputs(&self, params: &Params) -> Result<Vec<(String, Vec<u8>)>, StageError> {
        let params = params.read::<Self>()?;
        let script = std::fs::read(&params.script)
            .map_err(|err| StageError::new(format!("{}: {err}", params.script.display())))?;
        Ok(vec![
            ("script".into(), script),
            ("gmsh".into(), gmsh_version()?.into_bytes()),
        ])
    }
    fn run(&self, params: &Params, _inputs: &Inputs) -> Result<Outputs, StageError> {
        let params = params.read::<Self>()?;
        let script = &params.script;
        let text = std::fs::read_to_string(script)
            .map_err(|err| StageError::new(format!("{}: {err}", script.display())))?;
        if !matches!(params.order, 1 | 2) {
            return Err(StageError::new(format!(
                "order = {}: Gmsh meshes of order 1 or 2 are read",
                params.order
            )));
        }
        if !(params.mesh_size > 0.0) || !params.mesh_size.is_finite() {
            return Err(StageError::new(format!(
                "mesh_size = {} m: the largest element size must be positive",
                params.mesh_size
            )));
        }
        let numbers = numbers(&params.set, &text)?;
        let options = params.reading.options()?;
        let dir = tempfile::tempdir()
            .map_err(|err| StageError::new(format!("a temporary folder for Gmsh: {err}")))?;
        let out = dir.path().join("mesh.msh");
        mesh_script(script, &params, &numbers, &out)?;
        let bytes = std::fs::read(&out).map_err(|err| {
            StageError::new(format!("Gmsh's mesh of {}: {err}", script.display()))
        })?;
        let mesh = read_msh_bytes(&bytes, &options).map_err(|err| {
            StageError::new(format!(
                "{} meshed by Gmsh: {}",
                script.display(),
                err.message
            ))
        })?;
        let summary = Table::quantities(&[
            ("nodes", mesh.nodes.len() as f64),
            ("elements", mesh.elements.len() as f64),
            ("dofs", 3.0 * mesh.nodes.len() as f64),
        ]);
        Ok(Outputs::from([
            ("mesh".to_string(), Artifact::Mesh(Box::new(mesh))),
            ("summary".to_string(), Artifact::Table(summary)),
        ]))
    }
}

#[cfg(test)]
mod tests;

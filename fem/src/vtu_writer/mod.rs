//! VTK XML unstructured grids (`.vtu`) of a mesh and fields on it (real and complex mode
//! shapes, an equilibrium), for ParaView (`File > Open`), PyVista (`pyvista.read`) or meshio.
//! The `vtu.*` stages (`squeal_model::export::vtu`) and the stages with a VTU output use it.
//!
//! # What is written
//!
//! Plain ASCII XML, VTK file format 1.0, one piece:
//!
//! ```text
//! <?xml version="1.0"?>
//! <!-- squeal: parts 0 = disc, 1 = pad -->
//! <VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">
//!   <UnstructuredGrid>
//!     <Piece NumberOfPoints="n" NumberOfCells="m">
//!       <PointData>  arrays on nodes (below)
//!       <CellData>   part: Int32, index into the part list of the comment above
//!       <Points>     Float64 x 3, node coordinates (m)
//!       <Cells>      connectivity: Int64; offsets: Int64; types: UInt8, the cells' VTK types
//!     </Piece>
//!   </UnstructuredGrid>
//! </VTKFile>
//! ```
//!
//! Cell types: `tet4` 10, `hex8` 12, `wedge6` 13, `tet10` 24, `hex20` 25, `wedge15` 26, with
//! their nodes in VTK's order ([`crate::element::formats`]: the same as squeal's but for
//! the wedges' first triangle, which VTK turns the other way round).
//! Numbers are written exactly (shortest representation that reads back to the same double).
//!
//! Point arrays of `vtu.mesh`: one UInt8 array per node set, named after it (1 on the set's
//! nodes, 0 elsewhere; `set_<name>` if the name is taken by a contact array), and with contact
//! pairs `contact` (UInt8: 0 no pair, 1 disc node, 2 pad node, every node of either side of a
//! pair), `contact_normal` (Float64 x 3, the pair's unit normal) and `contact_area` (Float64,
//! m², the pair's area), both at the disc node of a node-to-node pair and at the pad anchor of a
//! weighted pair (a mortar row's own node).
//!
//! Point arrays of `vtu.modes`: one Float64 x 3 array per mode, `mode_0001_1234.5Hz` (number
//! from 1, frequency ω/2π in Hz), the mass-normalised shape expanded from the free DOFs to the
//! nodes with zeros at clamped DOFs. In ParaView, colour by a mode's magnitude to see where it
//! moves, or apply `Warp By Vector` with it to see the deformed shape.

use std::f64::consts::PI;
use std::fmt::Write;

use crate::artifact::mesh::Mesh;
use crate::artifact::{Equilibrium, Model, RealModes};
use crate::element::formats::{self, Format};
use crate::value::StageError;

/// Point arrays `vtu.mesh` writes for contact pairs; node sets of these names are renamed.
const CONTACT_ARRAYS: [&str; 3] = ["contact", "contact_normal", "contact_area"];

/// The VTU text of a mesh: parts, node sets, contact pairs.
pub fn mesh_vtu(mesh: &Mesh) -> Result<String, String> {
    check_mesh(mesh)?;
    let n_nodes = mesh.n_nodes();
    let mut point_data = Vec::new();
    for (name, nodes) in &mesh.node_sets {
        let mut member = vec![0u8; n_nodes];
        for node in nodes {
            member[*node as usize] = 1;
        }
        let name = if CONTACT_ARRAYS.contains(&name.as_str()) && !mesh.contact_pairs.is_empty() {
            format!("set_{name}")
        } else {
            name.clone()
        };
        point_data.push(DataArray::new(name, 1, Values::UInt8(member)));
    }
    if !mesh.contact_pairs.is_empty() {
        let mut side = vec![0u8; n_nodes];
        let mut normal = vec![0.0; 3 * n_nodes];
        let mut area = vec![0.0; n_nodes];
        for pair in &mesh.contact_pairs {
            for &(node, _) in &pair.disc {
                side[node as usize] = 1;
            }
            for &(node, _) in &pair.pad {
                side[node as usize] = 2;
            }
            // At the disc node node to node; at the pad anchor of a weighted pair (its row's
            // node, whose normal and weight they are).
            let at = pair.single_disc_node().unwrap_or(pair.pad_node()) as usize;
            normal[3 * at..3 * at + 3].copy_from_slice(&pair.normal);
            area[at] = pair.area;
        }
        point_data.push(DataArray::new("contact", 1, Values::UInt8(side)));
        point_data.push(DataArray::new("contact_normal", 3, Values::Float64(normal)));
        point_data.push(DataArray::new("contact_area", 1, Values::Float64(area)));
    }
    write_grid(mesh, &point_data)
}

/// The VTU text of the first `max_modes` modes on the model's mesh.
pub fn modes_vtu(model: &Model, modes: &RealModes, max_modes: usize) -> Result<String, StageError> {
    model.check_dof_map()?;
    let n_dofs = model.n_dofs();
    if modes.omega.len() != modes.shapes.len() {
        return Err(StageError::new(format!(
            "modes have {} frequencies but {} shapes",
            modes.omega.len(),
            modes.shapes.len()
        )));
    }
    let mut point_data = Vec::new();
    for (mode_idx, (omega, shape)) in modes
        .omega
        .iter()
        .zip(&modes.shapes)
        .enumerate()
        .take(max_modes)
    {
        let number = mode_idx + 1;
        if shape.len() != n_dofs {
            return Err(StageError::new(format!(
                "mode {number} has {} values, the model has {n_dofs} DOFs",
                shape.len()
            )));
        }
        let name = format!("mode_{number:04}_{:.1}Hz", omega / (2.0 * PI));
        point_data.push(DataArray::new(
            name,
            3,
            Values::Float64(nodal_vectors(model, shape)),
        ));
    }
    write_grid(&model.mesh, &point_data).map_err(StageError::new)
}

/// The VTU text of complex mode shapes over the free DOFs: for each `(name, real, imaginary)`
/// two vector fields `<name>_re` and `<name>_im` (animate `re·cos ωt − im·sin ωt` in ParaView).
pub fn complex_modes_vtu(
    model: &Model,
    modes: &[(String, Vec<f64>, Vec<f64>)],
) -> Result<String, StageError> {
    model.check_dof_map()?;
    let mut point_data = Vec::new();
    for (name, real, imaginary) in modes {
        for (suffix, part) in [("re", real), ("im", imaginary)] {
            if part.len() != model.n_dofs() {
                return Err(StageError::new(format!(
                    "mode {name} has {} values, the model has {} DOFs",
                    part.len(),
                    model.n_dofs()
                )));
            }
            point_data.push(DataArray::new(
                format!("{name}_{suffix}"),
                3,
                Values::Float64(nodal_vectors(model, part)),
            ));
        }
    }
    write_grid(&model.mesh, &point_data).map_err(StageError::new)
}

/// A field over the free DOFs as one 3-vector per node, zero on clamped DOFs, a tied node's
/// its masters' by their weights ([`Model::nodal_displacements`]).
fn nodal_vectors(model: &Model, field: &[f64]) -> Vec<f64> {
    model.nodal_displacements(field)
}

/// The VTU text of a sliding equilibrium: the displacement (elastic part, without the pads'
/// rigid approach) and, on both nodes of each node-to-node pair (on the pad anchor of a
/// weighted pair), the contact pressure r_n / area (Pa) and the normal gap (m).
pub fn equilibrium_vtu(model: &Model, equilibrium: &Equilibrium) -> Result<String, StageError> {
    model.check_dof_map()?;
    equilibrium.check_belongs_to(model)?;
    let n_nodes = model.mesh.n_nodes();
    let (mut pressure, mut gap) = (vec![0.0; n_nodes], vec![0.0; n_nodes]);
    for ((pair, r_n), pair_gap) in model
        .mesh
        .contact_pairs
        .iter()
        .zip(&equilibrium.r_n)
        .zip(&equilibrium.gap)
    {
        // The pad anchor and, node to node, the disc node.
        for node in [pair.single_disc_node(), Some(pair.pad_node())]
            .into_iter()
            .flatten()
        {
            pressure[node as usize] = r_n / pair.area;
            gap[node as usize] = *pair_gap;
        }
    }
    let point_data = vec![
        DataArray::new(
            "displacement",
            3,
            Values::Float64(nodal_vectors(model, &equilibrium.u)),
        ),
        DataArray::new("contact_pressure", 1, Values::Float64(pressure)),
        DataArray::new("contact_gap", 1, Values::Float64(gap)),
    ];
    write_grid(&model.mesh, &point_data).map_err(StageError::new)
}

/// The values of one data array.
enum Values {
    UInt8(Vec<u8>),
    Int32(Vec<i32>),
    Int64(Vec<i64>),
    Float64(Vec<f64>),
}

impl Values {
    fn vtk_type(&self) -> &'static str {
        match self {
            Values::UInt8(_) => "UInt8",
            Values::Int32(_) => "Int32",
            Values::Int64(_) => "Int64",
            Values::Float64(_) => "Float64",
        }
    }
}

/// A named VTK data array of `components` values per tuple.
struct DataArray {
    name: String,
    components: usize,
    values: Values,
}

impl DataArray {
    fn new(name: impl Into<String>, components: usize, values: Values) -> Self {
        DataArray {
            name: name.into(),
            components,
            values,
        }
    }

    /// Writes `<DataArray ...>values</DataArray>`, `per_line` values on a line.
    fn write(&self, out: &mut String, indent: &str, per_line: usize) -> Result<(), String> {
        let _ = write!(
            out,
            "{indent}<DataArray type=\"{}\" Name=\"{}\"",
            self.values.vtk_type(),
            escape_attribute(&self.name)
        );
        if self.components > 1 {
            let _ = write!(out, " NumberOfComponents=\"{}\"", self.components);
        }
        let _ = writeln!(out, " format=\"ascii\">");
        let per_line = per_line.max(1);
        let line = |idx: usize, out: &mut String| {
            if idx.is_multiple_of(per_line) {
                if idx > 0 {
                    out.push('\n');
                }
                out.push_str(indent);
                out.push_str("  ");
            } else {
                out.push(' ');
            }
        };
        match &self.values {
            Values::UInt8(values) => values.iter().enumerate().for_each(|(idx, value)| {
                line(idx, out);
                let _ = write!(out, "{value}");
            }),
            Values::Int32(values) => values.iter().enumerate().for_each(|(idx, value)| {
                line(idx, out);
                let _ = write!(out, "{value}");
            }),
            Values::Int64(values) => values.iter().enumerate().for_each(|(idx, value)| {
                line(idx, out);
                let _ = write!(out, "{value}");
            }),
            Values::Float64(values) => {
                for (idx, value) in values.iter().enumerate() {
                    if !value.is_finite() {
                        return Err(format!(
                            "array `{}` has a non-finite value at tuple {}",
                            self.name,
                            idx / self.components
                        ));
                    }
                    line(idx, out);
                    write_float(out, *value);
                }
            }
        }
        let _ = writeln!(out, "\n{indent}</DataArray>");
        Ok(())
    }
}

/// Writes a double exactly, in plain notation where that stays short, else in exponent form.
fn write_float(out: &mut String, value: f64) {
    let magnitude = value.abs();
    if value == 0.0 || (1e-4..1e15).contains(&magnitude) {
        let _ = write!(out, "{value}");
    } else {
        let _ = write!(out, "{value:e}");
    }
}

fn escape_attribute(text: &str) -> String {
    let mut escaped = String::with_capacity(text.len());
    for ch in text.chars() {
        match ch {
            '&' => escaped.push_str("&amp;"),
            '<' => escaped.push_str("&lt;"),
            '>' => escaped.push_str("&gt;"),
            '"' => escaped.push_str("&quot;"),
            _ => escaped.push(ch),
        }
    }
    escaped
}

/// Checks every index of the mesh, so that writing it cannot go out of bounds.
fn check_mesh(mesh: &Mesh) -> Result<(), String> {
    let n_nodes = mesh.n_nodes();
    mesh.elements
        .check(n_nodes, mesh.parts.len())
        .map_err(|err| format!("mesh: {err}"))?;
    for (name, nodes) in &mesh.node_sets {
        if nodes.iter().any(|node| *node as usize >= n_nodes) {
            return Err(format!(
                "mesh node set `{name}` refers to a node beyond the {n_nodes} nodes"
            ));
        }
    }
    if mesh
        .contact_pairs
        .iter()
        .any(|pair| pair.nodes().any(|node| node as usize >= n_nodes))
    {
        return Err(format!(
            "a mesh contact pair refers to a node beyond the {n_nodes} nodes"
        ));
    }
    Ok(())
}

/// The whole VTU document: the mesh's points, cells and parts, plus `point_data`.
fn write_grid(mesh: &Mesh, point_data: &[DataArray]) -> Result<String, String> {
    check_mesh(mesh)?;
    let n_nodes = mesh.n_nodes();
    let n_cells = mesh.elements.len();
    // Roughly 25 bytes per number.
    let n_numbers = 3 * n_nodes
        + 10 * n_cells
        + point_data
            .iter()
            .map(|array| array.components * n_nodes)
            .sum::<usize>();
    let mut out = String::with_capacity(1024 + 25 * n_numbers);
    out.push_str("<?xml version=\"1.0\"?>\n");
    let parts: Vec<String> = mesh
        .parts
        .iter()
        .enumerate()
        .map(|(idx, name)| format!("{idx} = {name}"))
        .collect();
    // "--" may not appear inside an XML comment.
    let comment = format!("squeal: parts {}", parts.join(", ")).replace("--", "- -");
    let _ = writeln!(out, "<!-- {comment} -->");
    out.push_str(
        "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n",
    );
    out.push_str("  <UnstructuredGrid>\n");
    let _ = writeln!(
        out,
        "    <Piece NumberOfPoints=\"{n_nodes}\" NumberOfCells=\"{n_cells}\">"
    );
    let indent = "        ";

    out.push_str("      <PointData>\n");
    for array in point_data {
        let per_line = if array.components > 1 {
            array.components
        } else {
            16
        };
        array.write(&mut out, indent, per_line)?;
    }
    out.push_str("      </PointData>\n");

    out.push_str("      <CellData>\n");
    let part: Vec<i32> = mesh
        .elements
        .parts()
        .iter()
        .map(|part| *part as i32)
        .collect();
    DataArray::new("part", 1, Values::Int32(part)).write(&mut out, indent, 16)?;
    out.push_str("      </CellData>\n");

    out.push_str("      <Points>\n");
    let coordinates: Vec<f64> = mesh.nodes.iter().flatten().copied().collect();
    DataArray::new("Points", 3, Values::Float64(coordinates)).write(&mut out, indent, 3)?;
    out.push_str("      </Points>\n");

    out.push_str("      <Cells>\n");
    let mut connectivity: Vec<i64> = Vec::with_capacity(mesh.elements.all_nodes().len());
    let mut offsets: Vec<i64> = Vec::with_capacity(n_cells);
    let mut types: Vec<u8> = Vec::with_capacity(n_cells);
    for element in mesh.elements.iter() {
        let nodes = formats::to_file(element.kind, Format::Vtk, element.nodes);
        connectivity.extend(nodes.iter().map(|node| i64::from(*node)));
        offsets.push(connectivity.len() as i64);
        types.push(formats::vtk_cell_type(element.kind));
    }
    DataArray::new("connectivity", 1, Values::Int64(connectivity)).write(&mut out, indent, 8)?;
    DataArray::new("offsets", 1, Values::Int64(offsets)).write(&mut out, indent, 16)?;
    DataArray::new("types", 1, Values::UInt8(types)).write(&mut out, indent, 16)?;
    out.push_str("      </Cells>\n");

    out.push_str("    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n");
    Ok(out)
}

#[cfg(test)]
mod tests;

use super::*;
use std::collections::BTreeMap;

use crate::artifact::CscMatrix;
use squeal_model::mesh::gmsh::{ReadOptions, read_msh};
use squeal_model::mesh::interface::ContactSides;
use squeal_model::mesh::structured::block;

/// A `<DataArray>` read back: its parent element, attributes and whitespace-split values.
#[derive(Debug)]
struct ParsedArray {
    parent: String,
    attributes: BTreeMap<String, String>,
    values: Vec<String>,
}

impl ParsedArray {
    fn floats(&self) -> Vec<f64> {
        self.values.iter().map(|v| v.parse().unwrap()).collect()
    }
    fn ints(&self) -> Vec<i64> {
        self.values.iter().map(|v| v.parse().unwrap()).collect()
    }
}

/// A small XML reader for what we write: checks that tags nest and close, returns the
/// `Piece` attributes and every data array.
fn parse_vtu(xml: &str) -> (BTreeMap<String, String>, Vec<ParsedArray>) {
    let mut stack: Vec<String> = Vec::new();
    let mut piece = BTreeMap::new();
    let mut arrays = Vec::new();
    let mut rest = xml;
    while let Some(open) = rest.find('<') {
        let text = &rest[..open];
        let close = rest[open..].find('>').expect("unclosed tag") + open;
        let tag = &rest[open + 1..close];
        if let Some(name) = tag.strip_prefix('/') {
            assert_eq!(stack.pop().as_deref(), Some(name), "mismatched </{name}>");
            if name == "DataArray" {
                let array: &mut ParsedArray = arrays.last_mut().unwrap();
                array.values = text.split_whitespace().map(String::from).collect();
            }
        } else if !tag.starts_with('?') && !tag.starts_with("!--") {
            let (name, attribute_text) = tag.split_once(' ').unwrap_or((tag, ""));
            let attributes = parse_attributes(attribute_text);
            if name == "Piece" {
                piece = attributes.clone();
            }
            if name == "DataArray" {
                arrays.push(ParsedArray {
                    parent: stack.last().cloned().unwrap_or_default(),
                    attributes,
                    values: Vec::new(),
                });
            }
            if !tag.ends_with('/') {
                stack.push(name.to_string());
            }
        }
        rest = &rest[close + 1..];
    }
    assert!(stack.is_empty(), "unclosed elements: {stack:?}");
    assert!(rest.trim().is_empty());
    (piece, arrays)
}

fn parse_attributes(text: &str) -> BTreeMap<String, String> {
    let mut attributes = BTreeMap::new();
    let mut rest = text.trim();
    while let Some(eq) = rest.find("=\"") {
        let name = rest[..eq].trim().to_string();
        let end = rest[eq + 2..].find('"').expect("unterminated attribute") + eq + 2;
        let value = rest[eq + 2..end]
            .replace("&quot;", "\"")
            .replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&amp;", "&");
        attributes.insert(name, value);
        rest = rest[end + 1..].trim();
    }
    attributes
}

fn array<'a>(arrays: &'a [ParsedArray], parent: &str, name: &str) -> &'a ParsedArray {
    arrays
        .iter()
        .find(|a| a.parent == parent && a.attributes.get("Name").map(String::as_str) == Some(name))
        .unwrap_or_else(|| panic!("no {parent} array `{name}`"))
}

fn two_part_mesh() -> Mesh {
    let path = format!(
        "{}/../model/tests/data/two_part.msh",
        env!("CARGO_MANIFEST_DIR")
    );
    let options = ReadOptions {
        contact: Some(ContactSides {
            disc: "contact_disc".into(),
            pad: "contact_pad".into(),
            relative_tolerance: 1e-3,
        }),
    };
    read_msh(&std::fs::read_to_string(path).unwrap(), &options).unwrap()
}

#[test]
fn mesh_vtu_reads_back_cells_points_parts_and_sets() {
    let mut mesh = two_part_mesh();
    // A name that needs escaping, and one that collides with a contact array.
    mesh.node_sets.insert("a<&\"b".into(), vec![0]);
    mesh.node_sets.insert("contact".into(), vec![1]);
    let xml = mesh_vtu(&mesh).unwrap();
    assert!(xml.contains("<!-- squeal: parts 0 = disc, 1 = pad -->"));
    let (piece, arrays) = parse_vtu(&xml);
    assert_eq!(piece["NumberOfPoints"], "24");
    assert_eq!(piece["NumberOfCells"], "4");

    let connectivity = array(&arrays, "Cells", "connectivity");
    assert_eq!(connectivity.attributes["type"], "Int64");
    let expected: Vec<i64> = mesh
        .elements
        .all_nodes()
        .iter()
        .map(|n| i64::from(*n))
        .collect();
    assert_eq!(connectivity.ints(), expected);
    assert_eq!(array(&arrays, "Cells", "offsets").ints(), [8, 16, 24, 32]);
    let types = array(&arrays, "Cells", "types");
    assert_eq!(
        (types.attributes["type"].as_str(), types.ints()),
        ("UInt8", vec![12; 4])
    );

    let points = array(&arrays, "Points", "Points");
    assert_eq!(points.attributes["NumberOfComponents"], "3");
    let expected: Vec<f64> = mesh.nodes.iter().flatten().copied().collect();
    assert_eq!(points.floats(), expected, "coordinates read back exactly");

    let part = array(&arrays, "CellData", "part");
    assert_eq!(
        (part.attributes["type"].as_str(), part.ints()),
        ("Int32", vec![0, 0, 1, 1])
    );

    let pad_back = array(&arrays, "PointData", "pad_back");
    assert_eq!(pad_back.attributes["type"], "UInt8");
    for (node, flag) in pad_back.ints().iter().enumerate() {
        let on_set = mesh.node_sets["pad_back"].contains(&(node as u32));
        assert_eq!(*flag, i64::from(on_set));
    }
    assert_eq!(array(&arrays, "PointData", "a<&\"b").ints()[0], 1);
    assert_eq!(array(&arrays, "PointData", "set_contact").ints()[1], 1);

    let contact = array(&arrays, "PointData", "contact").ints();
    assert_eq!(contact.iter().filter(|side| **side == 1).count(), 6);
    assert_eq!(contact.iter().filter(|side| **side == 2).count(), 6);
    for pair in &mesh.contact_pairs {
        assert_eq!(
            (
                contact[pair.disc[0].0 as usize],
                contact[pair.pad_node() as usize]
            ),
            (1, 2)
        );
    }
    let normal = array(&arrays, "PointData", "contact_normal").floats();
    for pair in &mesh.contact_pairs {
        let disc = pair.disc[0].0 as usize;
        assert_eq!(
            normal[3 * disc..3 * disc + 3],
            pair.normal,
            "read back exactly"
        );
    }
    let area: f64 = array(&arrays, "PointData", "contact_area")
        .floats()
        .iter()
        .sum();
    assert!((area - 2.0).abs() < 1e-12);
}

/// A 2 x 1 x 1 block clamped on its face x = 0, with two made-up modes.
fn clamped_block() -> (Model, RealModes) {
    let mesh = block([2.0, 1.0, 1.0], [2, 1, 1], "steel");
    let clamped = &mesh.node_sets["x0"];
    let mut n_dofs = 0u32;
    let dof_of_node: Vec<[Option<u32>; 3]> = (0..mesh.n_nodes() as u32)
        .map(|node| {
            if clamped.contains(&node) {
                [None; 3]
            } else {
                n_dofs += 3;
                [Some(n_dofs - 3), Some(n_dofs - 2), Some(n_dofs - 1)]
            }
        })
        .collect();
    let n = n_dofs as usize;
    let identity = CscMatrix {
        n_rows: n,
        n_cols: n,
        col_ptr: (0..=n).collect(),
        row_idx: (0..n).collect(),
        values: vec![1.0; n],
    };
    let model = Model {
        mesh,
        dof_of_node,
        M: identity.clone(),
        K: identity.clone(),
        C: identity,
        tied: Vec::new(),
    };
    let modes = RealModes {
        omega: vec![2.0 * PI * 100.0, 2.0 * PI * 250.3],
        shapes: vec![
            (0..n).map(|dof| dof as f64 / 7.0).collect(),
            (0..n).map(|dof| -1e-20 * dof as f64).collect(),
        ],
        residuals: vec![1e-14, 1e-13],
    };
    (model, modes)
}

#[test]
fn modes_vtu_expands_shapes_to_nodes_with_zeros_where_clamped() {
    let (model, modes) = clamped_block();
    let vtu = modes_vtu(&model, &modes, 20).unwrap();
    let (piece, arrays) = parse_vtu(&vtu);
    assert_eq!(piece["NumberOfPoints"], "12");
    let names: Vec<&str> = arrays
        .iter()
        .filter(|a| a.parent == "PointData")
        .map(|a| a.attributes["Name"].as_str())
        .collect();
    assert_eq!(names, ["mode_0001_100.0Hz", "mode_0002_250.3Hz"]);
    for (mode_idx, name) in names.iter().enumerate() {
        let values = array(&arrays, "PointData", name);
        assert_eq!(values.attributes["NumberOfComponents"], "3");
        let values = values.floats();
        assert_eq!(values.len(), 3 * 12);
        for (node, dofs) in model.dof_of_node.iter().enumerate() {
            for (axis, dof) in dofs.iter().enumerate() {
                let expected = dof.map_or(0.0, |dof| modes.shapes[mode_idx][dof as usize]);
                assert_eq!(
                    values[3 * node + axis],
                    expected,
                    "mode {name}, node {node}"
                );
            }
        }
    }
    assert_eq!(array(&arrays, "CellData", "part").ints(), [0, 0]);

    let vtu = modes_vtu(&model, &modes, 1).unwrap();
    let (_, arrays) = parse_vtu(&vtu);
    assert_eq!(arrays.iter().filter(|a| a.parent == "PointData").count(), 1);
}

#[test]
fn inconsistent_inputs_are_refused_in_one_line() {
    let (model, mut modes) = clamped_block();
    modes.shapes[1].pop();
    let err = modes_vtu(&model, &modes, 20).unwrap_err();
    assert!(
        err.message
            .contains("mode 2 has 23 values, the model has 24 DOFs"),
        "{err}"
    );

    let (model, mut modes) = clamped_block();
    modes.shapes[0][4] = f64::NAN;
    let err = modes_vtu(&model, &modes, 20).unwrap_err();
    assert!(
        err.message
            .contains("`mode_0001_100.0Hz` has a non-finite value"),
        "{err}"
    );

    let mut mesh = block([1.0, 1.0, 1.0], [1, 1, 1], "steel");
    mesh.elements.nodes_mut(0)[7] = 99;
    let err = mesh_vtu(&mesh).unwrap_err();
    assert!(
        err.contains("element 0 names node 99, but the mesh has 8 nodes"),
        "{err}"
    );
}

/// VTK's own description of its cells, written out here independently of squeal's tables:
/// the cell type, the edge of each mid-edge node (VTK numbering), and whether the first
/// face's right-hand normal points toward the remaining corners (tetrahedra and hexahedra) or
/// away from them (wedges, whose first triangle VTK turns the other way round).
fn vtk_cell(cell_type: u8) -> (usize, Vec<[usize; 2]>, bool) {
    let tet = vec![[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]];
    let wedge = vec![
        [0, 1],
        [1, 2],
        [2, 0],
        [3, 4],
        [4, 5],
        [5, 3],
        [0, 3],
        [1, 4],
        [2, 5],
    ];
    let hex = vec![
        [0, 1],
        [1, 2],
        [2, 3],
        [3, 0],
        [4, 5],
        [5, 6],
        [6, 7],
        [7, 4],
        [0, 4],
        [1, 5],
        [2, 6],
        [3, 7],
    ];
    match cell_type {
        10 => (4, vec![], true),
        24 => (4, tet, true),
        13 => (6, vec![], false),
        26 => (6, wedge, false),
        12 => (8, vec![], true),
        25 => (8, hex, true),
        other => panic!("unexpected VTK cell type {other}"),
    }
}

#[test]
fn cells_of_every_kind_follow_vtk_conventions() {
    use crate::artifact::ElementKind;
    use crate::artifact::mesh::{cross, dot, norm, sub};
    use squeal_model::mesh::convert::{split_hexahedra, with_mid_edge_nodes};
    let hexes = block([0.2, 0.1, 0.05], [2, 1, 1], "steel");
    let tets = split_hexahedra(&hexes, ElementKind::Tet4).unwrap();
    let wedges = split_hexahedra(&hexes, ElementKind::Wedge6).unwrap();
    for mesh in [
        hexes.clone(),
        with_mid_edge_nodes(&hexes),
        tets.clone(),
        with_mid_edge_nodes(&tets),
        wedges.clone(),
        with_mid_edge_nodes(&wedges),
    ] {
        let xml = mesh_vtu(&mesh).unwrap();
        let (_, arrays) = parse_vtu(&xml);
        let connectivity = array(&arrays, "Cells", "connectivity").ints();
        let offsets = array(&arrays, "Cells", "offsets").ints();
        let types = array(&arrays, "Cells", "types").ints();
        assert_eq!(types.len(), mesh.elements.len());
        let point = |node: i64| mesh.nodes[node as usize];
        let mut start = 0;
        for (cell, (&end, &cell_type)) in offsets.iter().zip(&types).enumerate() {
            let nodes = &connectivity[start as usize..end as usize];
            start = end;
            let (n_corners, edges, toward) = vtk_cell(cell_type as u8);
            assert_eq!(nodes.len(), n_corners + edges.len(), "cell {cell}");
            // Orientation of the first face against the corner that follows it.
            let [a, b, c] = [point(nodes[0]), point(nodes[1]), point(nodes[2])];
            let normal = cross(sub(b, a), sub(c, a));
            let other = point(nodes[if n_corners == 4 { 3 } else { n_corners / 2 }]);
            assert_eq!(
                dot(normal, sub(other, a)) > 0.0,
                toward,
                "cell {cell} type {cell_type}"
            );
            // Each mid-edge node at the middle of its VTK edge (the meshes are straight).
            for (k, [p, q]) in edges.iter().enumerate() {
                let middle: [f64; 3] =
                    std::array::from_fn(|i| 0.5 * (point(nodes[*p])[i] + point(nodes[*q])[i]));
                assert!(
                    norm(sub(point(nodes[n_corners + k]), middle)) < 1e-15,
                    "cell {cell}"
                );
            }
        }
    }
}

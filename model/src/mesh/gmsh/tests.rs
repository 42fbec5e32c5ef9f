use std::collections::BTreeMap;

use super::build::*;
use super::parse::*;
use super::*;
use crate::artifact::mesh::{norm, sub};
use crate::stage::Value;

fn data(name: &str) -> String {
    let path = format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read_to_string(&path).unwrap_or_else(|err| panic!("{path}: {err}"))
}

fn with_contact() -> ReadOptions {
    ReadOptions {
        contact: Some(ContactSides {
            disc: "contact_disc".into(),
            pad: "contact_pad".into(),
            relative_tolerance: 1e-3,
        }),
    }
}

/// Reading `text` fails on `line` with a message containing `expected`.
fn check_error(text: &str, options: &ReadOptions, line: Option<usize>, expected: &str) {
    let err = read_msh(text, options).expect_err("the file should be refused");
    assert_eq!(err.line, line, "{err}");
    assert!(err.message.contains(expected), "`{err}` lacks `{expected}`");
    assert!(!err.message.contains('\n'), "one line: {err}");
}

/// The 1-based number of the first line of `text` that contains `needle`.
fn line_of(text: &str, needle: &str) -> usize {
    1 + text
        .lines()
        .position(|line| line.contains(needle))
        .unwrap_or_else(|| panic!("no line holds `{needle}`"))
}

#[test]
fn block_reads_hexes_part_and_face_set() {
    let mesh = read_msh(&data("block_2x1x1.msh"), &ReadOptions::default()).unwrap();
    assert_eq!(mesh.nodes.len(), 12);
    assert_eq!(mesh.parts, ["steel"]);
    assert_eq!(mesh.elements.parts(), [0, 0]);
    // Tags 1..12 become 0..11; connectivity is copied in Gmsh order.
    assert_eq!(mesh.elements.nodes(0), [0, 4, 6, 1, 3, 8, 10, 2]);
    assert_eq!(mesh.elements.nodes(1), [4, 5, 7, 6, 8, 9, 11, 10]);
    assert_eq!(mesh.nodes[5], [2.0, 0.0, 0.0]);
    assert_eq!(mesh.node_sets.keys().collect::<Vec<_>>(), ["x0"]);
    assert_eq!(mesh.node_sets["x0"], [0, 1, 2, 3]);
    assert!(
        mesh.node_sets["x0"]
            .iter()
            .all(|n| mesh.nodes[*n as usize][0] == 0.0)
    );
    assert!(mesh.contact_pairs.is_empty());
}

#[test]
fn two_parts_pair_duplicated_interface_nodes() {
    let mesh = read_msh(&data("two_part.msh"), &with_contact()).unwrap();
    assert_eq!(mesh.parts, ["disc", "pad"]);
    assert_eq!(mesh.elements.parts(), [0, 0, 1, 1]);
    assert_eq!(mesh.nodes.len(), 24);
    assert_eq!(mesh.contact_pairs.len(), 6);
    for pair in &mesh.contact_pairs {
        assert!(pair.is_node_to_node());
        let disc = pair.disc_position(&mesh.nodes);
        let pad = pair.pad_position(&mesh.nodes);
        assert_ne!(pair.disc[0].0, pair.pad_node());
        assert!(norm(sub(disc, pad)) < 1e-8, "{disc:?} {pad:?}");
        // One face is written clockwise in the file: the normal is oriented all the same.
        assert!(norm(sub(pair.normal, [0.0, 0.0, 1.0])) < 1e-12, "{pair:?}");
        // Corner nodes take a quarter of one unit face, the middle ones two quarters.
        let expected = if disc[0] == 1.0 { 0.5 } else { 0.25 };
        assert!((pair.area - expected).abs() < 1e-12, "{pair:?}");
    }
    let total: f64 = mesh.contact_pairs.iter().map(|pair| pair.area).sum();
    assert!((total - 2.0).abs() < 1e-12);
    assert_eq!(mesh.node_sets["pad_back"].len(), 6);
    assert_eq!(mesh.node_sets["contact_disc"].len(), 6);
}

#[test]
fn tilted_face_has_its_normal_and_area() {
    // Rotate the two-part block about x by 30°: normals rotate, areas stay.
    let angle = 30f64.to_radians();
    let text = data("two_part.msh");
    let mesh = read_msh(&text, &with_contact()).unwrap();
    let mut rotated = mesh.clone();
    for node in &mut rotated.nodes {
        let [x, y, z] = *node;
        *node = [
            x,
            y * angle.cos() - z * angle.sin(),
            y * angle.sin() + z * angle.cos(),
        ];
    }
    let elements = parse_elements_of(&text);
    let index_of_tag = tags_to_indices(&text);
    let contact = with_contact().contact.unwrap();
    let pairs = pair_contact_nodes(&rotated, &elements, &index_of_tag, &contact).unwrap();
    let expected = [0.0, -angle.sin(), angle.cos()];
    for (pair, original) in pairs.iter().zip(&mesh.contact_pairs) {
        assert!(norm(sub(pair.normal, expected)) < 1e-12, "{pair:?}");
        assert!((pair.area - original.area).abs() < 1e-12);
    }
}

fn parse_elements_of(text: &str) -> Elements {
    let sections = split_sections(text).unwrap();
    let find = |name: &str| sections.iter().find(|s| s.name == name).unwrap();
    let names = parse_physical_names(find("PhysicalNames")).unwrap();
    let entities = parse_entities(find("Entities")).unwrap();
    let nodes = parse_nodes(find("Nodes")).unwrap();
    parse_elements(find("Elements"), &nodes, &entities, &names).unwrap()
}

fn tags_to_indices(text: &str) -> HashMap<u64, u32> {
    let elements = parse_elements_of(text);
    let mut tags: Vec<u64> = elements
        .solids
        .iter()
        .flat_map(|solid| solid.nodes.iter().copied())
        .collect();
    tags.sort_unstable();
    tags.dedup();
    tags.into_iter().zip(0..).collect()
}

#[test]
fn file_written_by_gmsh_reads_the_same() {
    // Written by Gmsh 4.15 (two OpenCASCADE boxes, transfinite, recombined): nodes are
    // classified on points, curves and surfaces, lines end with a space.
    let mesh = read_msh(&data("two_part_gmsh.msh"), &with_contact()).unwrap();
    assert_eq!(mesh.parts, ["disc", "pad"]);
    assert_eq!(mesh.elements.len(), 4);
    assert_eq!(mesh.nodes.len(), 24);
    assert_eq!(mesh.contact_pairs.len(), 6);
    let total: f64 = mesh.contact_pairs.iter().map(|pair| pair.area).sum();
    assert!((total - 2.0).abs() < 1e-12);
    for pair in &mesh.contact_pairs {
        assert!(norm(sub(pair.normal, [0.0, 0.0, 1.0])) < 1e-12, "{pair:?}");
    }
    assert_eq!(mesh.node_sets["clamp"].len(), 6);
    assert!(
        mesh.node_sets["clamp"]
            .iter()
            .all(|n| mesh.nodes[*n as usize][2] == 0.0)
    );
}

#[test]
fn stage_reads_the_file_and_names_it_in_errors() {
    let stage = GmshImport;
    assert!(!stage.pure());
    let params = |path: &str, disc: &str, pad: &str| {
        Params(BTreeMap::from([
            ("path".to_string(), Value::Str(path.into())),
            ("contact_disc".to_string(), Value::Str(disc.into())),
            ("contact_pad".to_string(), Value::Str(pad.into())),
            ("contact_tolerance".to_string(), Value::Float(1e-3)),
        ]))
    };
    let path = format!("{}/tests/data/two_part.msh", env!("CARGO_MANIFEST_DIR"));
    let outputs = stage
        .run(
            &params(&path, "contact_disc", "contact_pad"),
            &Inputs::default(),
        )
        .unwrap();
    let Artifact::Mesh(mesh) = &outputs["mesh"] else {
        panic!("not a mesh")
    };
    assert_eq!(mesh.contact_pairs.len(), 6);

    let block = format!("{}/tests/data/block_2x1x1.msh", env!("CARGO_MANIFEST_DIR"));
    let err = stage
        .run(
            &params(&block, "contact_disc", "contact_pad"),
            &Inputs::default(),
        )
        .unwrap_err();
    assert!(
        err.message.starts_with(&format!("{block}: contact_disc")),
        "{err}"
    );
    assert!(err.message.contains("physical surfaces: x0"), "{err}");
    assert!(
        stage
            .run(&params(&block, "", ""), &Inputs::default())
            .is_ok()
    );

    let err = stage
        .run(&params(&block, "contact_disc", ""), &Inputs::default())
        .unwrap_err();
    assert!(err.message.contains("both"), "{err}");

    // Parse errors carry `file:line:`.
    let old_format =
        std::env::temp_dir().join(format!("squeal-gmsh-old-format-{}.msh", std::process::id()));
    let text = std::fs::read_to_string(&block).unwrap();
    std::fs::write(&old_format, text.replace("4.1 0 8", "2.2 0 8")).unwrap();
    let old_format = old_format.to_string_lossy().into_owned();
    let err = stage
        .run(&params(&old_format, "", ""), &Inputs::default())
        .unwrap_err();
    let _ = std::fs::remove_file(&old_format);
    assert!(
        err.message
            .starts_with(&format!("{old_format}:2: MSH 2.2 is not supported")),
        "{err}"
    );

    let missing = format!("{}/tests/data/no_such.msh", env!("CARGO_MANIFEST_DIR"));
    let err = stage
        .run(&params(&missing, "", ""), &Inputs::default())
        .unwrap_err();
    assert!(err.message.starts_with(&missing), "{err}");
}

#[test]
fn unsupported_formats_are_refused_on_their_header_line() {
    let block = data("block_2x1x1.msh");
    let none = ReadOptions::default();
    check_error(
        &block.replace("4.1 0 8", "2.2 0 8"),
        &none,
        Some(2),
        "MSH 2.2 is not supported",
    );
    check_error(
        &block.replace("4.1 0 8", "4 0 8"),
        &none,
        Some(2),
        "MSH 4 is not supported",
    );
    check_error(
        &block.replace("4.1 0 8", "4.1 1 8"),
        &none,
        Some(2),
        "binary MSH",
    );
    check_error("$Nodes\n", &none, Some(1), "not a Gmsh MSH file");

    // A binary file is refused from its header, before its bytes are decoded.
    let mut binary = b"$MeshFormat\n4.1 1 8\n".to_vec();
    binary.extend_from_slice(&[1, 0, 0, 0, 0xff, 0xfe, b'\n']);
    let err = read_msh_bytes(&binary, &none).unwrap_err();
    assert!(err.message.contains("binary MSH"), "{err}");
    let mut garbage = block.clone().into_bytes();
    garbage.extend_from_slice(&[0xff, 0xfe]);
    let err = read_msh_bytes(&garbage, &none).unwrap_err();
    assert!(err.message.contains("not UTF-8"), "{err}");
}

#[test]
fn unsupported_elements_are_named() {
    let block = data("block_2x1x1.msh");
    let none = ReadOptions::default();
    // A pyramid block.
    let pyramids = block.replace("3 1 5 2\n", "3 1 7 2\n");
    check_error(
        &pyramids,
        &none,
        Some(line_of(&pyramids, "3 1 7 2")),
        "volume 1: 5-node pyramid (Gmsh type 7) elements are not supported, only tetrahedra (types 4, 11), hexahedra (5, 17) and prisms (6, 18)",
    );
    // A second-order hexahedron block.
    let quadratic = block.replace("3 1 5 2\n", "3 1 12 2\n");
    check_error(
        &quadratic,
        &none,
        Some(line_of(&quadratic, "3 1 12 2")),
        "27-node hexahedron",
    );
    // Second-order quadrangles on a named surface.
    let faces = block.replace("2 1 3 1\n", "2 1 10 1\n");
    check_error(
        &faces,
        &none,
        Some(line_of(&faces, "2 1 10 1")),
        "9-node quadrangle",
    );
    // A hexahedron missing a node.
    let short = block.replace("2 5 6 8 7 9 10 12 11", "2 5 6 8 7 9 10 12");
    check_error(
        &short,
        &none,
        Some(line_of(&short, "2 5 6 8 7 9 10 12")),
        "needs 8 nodes, found 7",
    );
}

#[test]
fn groups_must_exist_be_named_and_hold_every_hexahedron() {
    let block = data("block_2x1x1.msh");
    let none = ReadOptions::default();
    // Volume entity 1 in no physical group.
    let orphan = block.replace("1 0 0 0 2 1 1 1 1 1 1 1", "1 0 0 0 2 1 1 0 1 1");
    check_error(
        &orphan,
        &none,
        Some(line_of(&orphan, "3 1 5 2")),
        "in no physical volume",
    );
    // Volume entity 1 in two groups.
    let twice = block.replace("1 0 0 0 2 1 1 1 1 1 1 1", "1 0 0 0 2 1 1 2 1 7 1 1");
    check_error(
        &twice,
        &none,
        Some(line_of(&twice, "3 1 5 2")),
        "2 physical volumes (steel, 7)",
    );
    // A group without a name.
    let unnamed = block.replace("3 1 \"steel\"", "3 9 \"steel\"");
    check_error(
        &unnamed,
        &none,
        Some(line_of(&unnamed, "3 1 5 2")),
        "physical volume 1 has no name",
    );
    // Contact groups asked of a mesh that has none.
    check_error(
        &block,
        &with_contact(),
        None,
        "no physical surface named `contact_disc`",
    );
}

#[test]
fn malformed_text_names_its_line() {
    let block = data("block_2x1x1.msh");
    let none = ReadOptions::default();
    let bad_number = block.replace("\n2 0 0\n", "\n2 0 zero\n");
    check_error(
        &bad_number,
        &none,
        Some(line_of(&bad_number, "2 0 zero")),
        "`zero` is not a valid number",
    );
    let unknown_node = block.replace("2 5 6 8 7 9 10 12 11", "2 5 6 8 7 9 10 12 99");
    check_error(
        &unknown_node,
        &none,
        Some(line_of(&unknown_node, "12 99")),
        "refers to node 99",
    );
    let truncated = &block[..block.find("$EndElements").unwrap()];
    check_error(
        truncated,
        &none,
        Some(line_of(truncated, "$Elements")),
        "not closed by $EndElements",
    );
    let inverted = block.replace("2 5 6 8 7 9 10 12 11", "2 9 10 12 11 5 6 8 7");
    check_error(
        &inverted,
        &none,
        Some(line_of(&inverted, "2 9 10 12 11 5 6 8 7")),
        "hexahedron 2 is inverted",
    );
    // The nodes of hexahedron 2 again, in another (right-handed) order.
    let duplicated = block
        .replace("2 3 1 3\n", "2 4 1 3\n")
        .replace("3 1 5 2\n", "3 1 5 3\n")
        .replace(
            "2 5 6 8 7 9 10 12 11\n",
            "2 5 6 8 7 9 10 12 11\n3 6 8 7 5 10 12 11 9\n",
        );
    check_error(
        &duplicated,
        &none,
        Some(line_of(&duplicated, "3 6 8 7 5 10 12 11 9")),
        "hexahedron 3 has the nodes of hexahedron 2: a duplicated element",
    );
    let miscounted = block.replace("2 3 1 3\n", "2 4 1 3\n");
    check_error(
        &miscounted,
        &none,
        Some(line_of(&miscounted, "2 4 1 3")),
        "announces 4 elements, blocks hold 3",
    );
}

#[test]
fn contact_nodes_must_match_one_to_one() {
    let two = data("two_part.msh");
    // Move a pad node away from its disc partner.
    let moved = two.replace("1.0000000001 1 0.5", "1.3 1 0.5");
    check_error(
        &moved,
        &with_contact(),
        None,
        "node 11 of `contact_disc` at (1, 1, 0.5) has no node of `contact_pad`",
    );
    // A loose tolerance finds two candidates.
    let mut loose = with_contact();
    loose.contact.as_mut().unwrap().relative_tolerance = 1.5;
    check_error(&two, &loose, None, "lower contact_tolerance");
    // A shared (not duplicated) interface node.
    let shared = two.replace("3 101 104 105 102", "3 7 104 105 102");
    check_error(&shared, &with_contact(), None, "node 7 is on both");
    // A triangle in a contact surface.
    let triangle = two.replace(
        "2 2 3 2\n3 101 104 105 102\n4 102 105 106 103\n",
        "2 2 2 2\n3 101 104 105\n4 102 105 106\n",
    );
    check_error(
        &triangle,
        &with_contact(),
        Some(line_of(&triangle, "3 101 104 105")),
        "element 3 is a 3-node triangle",
    );
}

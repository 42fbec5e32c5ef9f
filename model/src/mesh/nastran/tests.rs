use std::path::{Path, PathBuf};

use super::*;
use crate::artifact::ElementKind;
use crate::artifact::mesh::{norm, sub};
use crate::mesh::gmsh;

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data")
}

#[test]
fn decks_written_by_pynastran_give_the_meshes_gmsh_wrote() {
    // tests/data/elements/make_nastran.py: the same meshes, grid points in a cylindrical
    // system, small fields (first order) or large fields (second order).
    let dir = data_dir().join("elements");
    for (stem, kind) in [
        ("tet1", ElementKind::Tet4),
        ("tet2", ElementKind::Tet10),
        ("wedge1", ElementKind::Wedge6),
        ("wedge2", ElementKind::Wedge15),
        ("hex1", ElementKind::Hex8),
        ("hex2", ElementKind::Hex20),
    ] {
        let text = std::fs::read_to_string(dir.join(format!("{stem}.msh"))).unwrap();
        let from_gmsh = gmsh::read_msh(&text, &gmsh::ReadOptions::default()).unwrap();
        let from_nastran = read_bdf(&dir.join(format!("{stem}.bdf")), &ReadOptions::default())
            .unwrap_or_else(|err| panic!("{stem}.bdf: {err}"));
        assert!(
            from_nastran
                .elements
                .iter()
                .all(|element| element.kind == kind),
            "{stem}"
        );
        assert_eq!(from_gmsh.elements, from_nastran.elements, "{stem}");
        assert_eq!(
            from_nastran.parts,
            ["disc"],
            "{stem}: named by its HMNAME comment"
        );
        assert_eq!(from_gmsh.nodes.len(), from_nastran.nodes.len(), "{stem}");
        // Small fields hold 8 characters (about 1e-7 m here), large fields 16.
        let precision = if kind.n_nodes() > kind.n_corners() {
            1e-14
        } else {
            1e-7
        };
        for (a, b) in from_gmsh.nodes.iter().zip(&from_nastran.nodes) {
            assert!(norm(sub(*a, *b)) < precision, "{stem}: {a:?} vs {b:?}");
        }
        assert_eq!(
            from_nastran.node_sets["set1"], from_gmsh.node_sets["bottom"],
            "{stem}"
        );
    }
}

/// Two hexahedra in free fields, one turned the other way round, Nastran reals, `THRU`.
const FREE: &str = "\
$ two hexahedra side by side
BEGIN BULK
GRID,1,,0.,0.,0.
GRID,2,,1.+0,0.,0.
GRID,3,,1.,1.,0.
GRID,4,,0.,1.,0.
GRID,5,,0.,0.,1.0D0
GRID,6,,1.,0.,1.
GRID,7,,1.,1.,1.
GRID,8,,0.,1.,1.
GRID,9,,2.,0.,0.
GRID,10,,2.,1.,0.
GRID,11,,2.,0.,1.
GRID,12,,2.,1.,1.
CHEXA,1,1,1,2,3,4,5,6,+
+,7,8
CHEXA,2,1,6,11,12,7,2,9,+
+,10,3
PSOLID,1,1
SPC1,3,123,1,THRU,4
SPC1,3,123,8
ENDDATA
";

#[test]
fn free_fields_turned_elements_and_thru_ranges_are_read() {
    let mesh = read_bdf_text(FREE, "free.bdf", &data_dir(), &ReadOptions::default()).unwrap();
    assert_eq!(mesh.elements.len(), 2);
    assert_eq!(mesh.parts, ["pid1"]);
    // The second hexahedron lists its top face first: it is turned, so that det J > 0.
    assert_eq!(mesh.elements.nodes(1), [1, 8, 9, 2, 5, 10, 11, 6]);
    assert_eq!(mesh.nodes[1], [1.0, 0.0, 0.0]);
    assert_eq!(mesh.nodes[4], [0.0, 0.0, 1.0]);
    assert_eq!(mesh.node_sets["spc3"], [0, 1, 2, 3, 7]);
    let parts = ReadOptions {
        parts: vec!["disc=1".into()],
        contact: None,
    };
    let named = read_bdf_text(FREE, "free.bdf", &data_dir(), &parts).unwrap();
    assert_eq!(named.parts, ["disc"]);
}

#[test]
fn small_and_large_fields_with_continuations_read_alike() {
    let small = "\
GRID           1       0      0.      0.      0.
GRID           2       0      1.      0.      0.
GRID           3       0      0.      1.      0.
GRID           4       0      0.      0.      1.
CTETRA         1       1       1       2       3       4
PSOLID         1       1
";
    let large = "\
GRID*                  1               0              0.              0.
*                     0.
GRID*                  2               0              1.              0.
*                     0.
GRID*                  3               0              0.              1.
*                     0.
GRID*                  4               0              0.              0.
*                     1.
CTETRA         1       1       1       2       3       4
PSOLID         1       1
";
    let a = read_bdf_text(small, "small.bdf", &data_dir(), &ReadOptions::default()).unwrap();
    let b = read_bdf_text(large, "large.bdf", &data_dir(), &ReadOptions::default()).unwrap();
    assert_eq!(a, b);
    assert_eq!(a.nodes[3], [0.0, 0.0, 1.0]);
}

#[test]
fn every_unsupported_or_malformed_card_is_refused_with_its_file_and_line() {
    let with = |from: &str, to: &str| FREE.replacen(from, to, 1);
    let cases: Vec<(String, &str, &str)> = vec![
        (
            with("PSOLID,1,1", "PSOLID,1,1\nRBE2,9,1,123456,2"),
            "free.bdf:20",
            "card RBE2 is not supported: rigid elements",
        ),
        (
            with("PSOLID,1,1", "PSOLID,1,1\nCQUAD4,9,1,1,2,3,4"),
            "free.bdf:20",
            "card CQUAD4 is not supported: shell elements",
        ),
        (
            with("PSOLID,1,1", "PSOLID,1,1\nFOO,1"),
            "free.bdf:20",
            "card FOO is not supported: squeal reads GRID",
        ),
        (
            with("+,7,8\n", "+,7\n"),
            "free.bdf:15",
            "CHEXA 1: 7 grid points, expected 8 or 20",
        ),
        (
            with("GRID,2,,1.+0,0.,0.", "GRID,2,5,1.,0.,0."),
            "free.bdf:4",
            "GRID 2: its CP 5 is no coordinate system",
        ),
        (
            with("GRID,3,,1.,1.,0.", "GRID,3,,1.x,1.,0."),
            "free.bdf:5",
            "GRID: a coordinate must be a number, found `1.x`",
        ),
        (
            with("GRID,4,,0.,1.,0.", "GRID,1,,0.,1.,0."),
            "free.bdf:6",
            "GRID 1 is defined twice (first at free.bdf:3)",
        ),
        (
            with("+,7,8\n", "+,7,99\n"),
            "free.bdf:15",
            "CHEXA 1: grid point 99 is not defined",
        ),
        (
            with(
                "CHEXA,2,1,6,11,12,7,2,9,+",
                "CHEXA,2,1,1,2,3,4,5,6,+\n+,7,8\nCHEXA,3,1,6,11,12,7,2,9,+",
            ),
            "free.bdf:17",
            "element 2 has the grid points of element 1",
        ),
        (
            with("GRID,5,,0.,0.,1.0D0", "GRID,5,,0.,0.,-1."),
            "free.bdf:15",
            "CHEXA 1 is inverted or degenerate",
        ),
        (
            with("BEGIN BULK", "BEGIN BULK\n+,1"),
            "free.bdf:3",
            "a continuation line with no card before it",
        ),
        (
            with("PSOLID,1,1", "PSOLID,1,1\nINCLUDE 'missing.bdf'"),
            "free.bdf:20",
            "INCLUDE 'missing.bdf'",
        ),
        (
            with(
                "PSOLID,1,1",
                "PSOLID,1,1\nCORD2R,4,5,0.,0.,0.,0.,0.,1.,+\n+,1.,0.,0.\nCORD2R,5,4,0.,0.,0.,0.,0.,1.,+\n+,1.,0.,0.",
            ),
            "free.bdf:",
            "defined in terms of each other",
        ),
        (
            with("SPC1,3,123,8", "SPC1,3,123,88"),
            "free.bdf:21",
            "grid point 88 belongs to no element",
        ),
        (
            with("PSOLID,1,1", "PSOLID,2,1"),
            "free.bdf:15",
            "CHEXA 1: property 1: no PSOLID defines it",
        ),
    ];
    for (text, at, expected) in cases {
        let err = read_bdf_text(&text, "free.bdf", &data_dir(), &ReadOptions::default())
            .expect_err(expected);
        assert!(err.at.starts_with(at), "`{err}` is not at {at}");
        assert!(err.message.contains(expected), "`{err}` lacks `{expected}`");
        assert!(!err.message.contains('\n'), "one line: {err}");
    }
    let unknown_part = ReadOptions {
        parts: vec!["disc=2".into()],
        contact: None,
    };
    let err = read_bdf_text(FREE, "free.bdf", &data_dir(), &unknown_part).unwrap_err();
    assert!(
        err.message
            .contains("parts: `disc=2`: no PSOLID 2 (properties: 1)"),
        "{err}"
    );
}

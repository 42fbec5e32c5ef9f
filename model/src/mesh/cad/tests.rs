//! `mesh.cad` on `tests/data/blocks.geo`. They need the Gmsh program (`python3 -m pip install
//! gmsh`): `.ci/run` installs it and runs them (their names start with `gmsh_`).

use std::path::PathBuf;

use super::*;
use crate::stage::Value;

fn blocks() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/blocks.geo")
}

fn params(script: &std::path::Path, overrides: &[(&str, Value)]) -> Params {
    let mut all = vec![
        ("script", Value::Str(script.display().to_string())),
        ("mesh_size", Value::Float(0.008)),
        ("contact_disc", Value::Str(String::new())),
        ("contact_pad", Value::Str(String::new())),
    ];
    for (name, value) in overrides {
        all.retain(|(other, _)| other != name);
        all.push((name, value.clone()));
    }
    Params::defaults(&MeshCad, &all)
}

fn mesh_bytes(params: &Params) -> (Vec<u8>, crate::artifact::mesh::Mesh) {
    let outputs = MeshCad.run(params, &Inputs::default()).unwrap();
    let Artifact::Mesh(mesh) = &outputs["mesh"] else {
        panic!("no mesh")
    };
    (outputs["mesh"].encode(), (**mesh).clone())
}

#[test]
#[ignore = "needs Gmsh; .ci/run runs it"]
fn gmsh_meshes_a_script_into_parts_and_sets_the_same_bytes_every_time() {
    let params = params(&blocks(), &[]);
    let (first, mesh) = mesh_bytes(&params);
    let (second, _) = mesh_bytes(&params);
    assert!(first == second, "two runs gave different meshes");
    // Second order: 10-node tetrahedra, in the two parts; the script's surfaces as node sets.
    assert!(
        mesh.elements
            .iter()
            .all(|element| element.nodes.len() == 10)
    );
    assert_eq!(mesh.parts, ["disc", "pad"]);
    for set in ["disc_top", "pad_bottom", "disc_bottom"] {
        assert!(mesh.node_sets.contains_key(set), "{set}");
    }
    // The pad's bottom lies on the disc's top at z = thickness.
    assert!(
        mesh.node_sets["pad_bottom"]
            .iter()
            .all(|&node| (mesh.nodes[node as usize][2] - 0.01).abs() < 1e-12)
    );
    // A set number reaches the geometry; first order gives 4-node tetrahedra.
    let (_, thicker) = mesh_bytes(&self::params(
        &blocks(),
        &[
            ("set", Value::Str("thickness=0.014".into())),
            ("order", Value::Int(1)),
        ],
    ));
    let top = &thicker.node_sets["disc_top"];
    assert!(
        top.iter()
            .all(|&node| (thicker.nodes[node as usize][2] - 0.014).abs() < 1e-12)
    );
    assert!(
        thicker
            .elements
            .iter()
            .all(|element| element.nodes.len() == 4)
    );
}

#[test]
#[ignore = "needs Gmsh; .ci/run runs it"]
fn gmsh_script_bytes_and_version_are_in_the_key_and_its_errors_are_gmshs() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("blocks.geo");
    let text = std::fs::read_to_string(blocks()).unwrap();
    std::fs::write(&script, &text).unwrap();
    let externals =
        |script: &std::path::Path| MeshCad.external_inputs(&params(script, &[])).unwrap();
    let before = externals(&script);
    assert_eq!(before[0], ("script".to_string(), text.clone().into_bytes()));
    assert_eq!(before[1].0, "gmsh");
    assert!(
        String::from_utf8_lossy(&before[1].1).starts_with('4'),
        "{before:?}"
    );
    std::fs::write(&script, text.replace("0.008", "0.009")).unwrap();
    assert_ne!(externals(&script), before);
    // A script Gmsh cannot read: its own error, with the script's name.
    std::fs::write(&script, text.replace("Box(2)", "Bxo(2)")).unwrap();
    let err = MeshCad
        .run(&params(&script, &[]), &Inputs::default())
        .unwrap_err();
    assert!(
        err.message
            .starts_with(&format!("{}: Gmsh failed: Error", script.display())),
        "{}",
        err.message
    );
    // A contact group the script does not define.
    std::fs::write(&script, &text).unwrap();
    let err = MeshCad
        .run(
            &params(
                &script,
                &[
                    ("contact_disc", Value::Str("disc_face".into())),
                    ("contact_pad", Value::Str("pad_bottom".into())),
                ],
            ),
            &Inputs::default(),
        )
        .unwrap_err();
    assert!(err.message.contains("disc_face"), "{}", err.message);
}

#[test]
fn set_numbers_are_name_value_items_the_script_mentions() {
    let script = "DefineConstant[ vanes = 36, thickness = 0.028 ];";
    assert_eq!(
        numbers(&["vanes=30".into(), " thickness = 0.03".into()], script).unwrap(),
        [("vanes".to_string(), 30.0), ("thickness".to_string(), 0.03)]
    );
    for (item, expected) in [
        ("vanes", "set: `vanes` is not name=value"),
        ("vanes=many", "set: `vanes=many`: `many` is not a number"),
        (
            "hat height=3",
            "set: `hat height=3`: `hat height` is not a Gmsh variable name",
        ),
        (
            "chamfer=1",
            "set: `chamfer` does not appear in the script: Gmsh would ignore it (declare it with DefineConstant)",
        ),
    ] {
        assert_eq!(
            numbers(&[item.into()], script).unwrap_err().message,
            expected
        );
    }
}

#[test]
fn a_missing_gmsh_says_how_to_install_it() {
    let err = version_of(std::path::Path::new("/nonexistent/gmsh")).unwrap_err();
    assert!(
        err.contains("install it with `python3 -m pip install gmsh`"),
        "{err}"
    );
}

//! The material kinds: what each declares becomes the material `assemble` reads, a frame
//! vector the frame would ignore and constants that are no material are refused.

use super::*;
use crate::stage::Value;

fn run(stage: &dyn Stage, values: &[(&str, Value)]) -> Result<Material, StageError> {
    let params = Params::defaults(stage, values);
    let outputs = stage.run(&params, &Inputs::default())?;
    match &outputs["material"] {
        Artifact::Material(material) => Ok((**material).clone()),
        other => panic!("a material, not {other:?}"),
    }
}

fn float(name: &str, value: f64) -> (&str, Value) {
    (name, Value::Float(value))
}

fn text<'a>(name: &'a str, value: &str) -> (&'a str, Value) {
    (name, Value::Str(value.to_string()))
}

/// A lining's constants, every one different.
fn orthotropic(extra: &[(&'static str, Value)]) -> Vec<(&'static str, Value)> {
    let mut values = vec![
        text("parts", "pad"),
        float("E_1", 9e9),
        float("E_2", 7e9),
        float("E_3", 3e9),
        float("nu_12", 0.25),
        float("nu_13", 0.12),
        float("nu_23", 0.18),
        float("G_12", 3.1e9),
        float("G_13", 1.4e9),
        float("G_23", 1.1e9),
        float("rho", 2500.0),
    ];
    values.extend(extra.iter().cloned());
    values
}

#[test]
fn each_kind_gives_its_law_for_the_parts_it_names() {
    let steel = run(
        &Isotropic,
        &[
            text("parts", "disc, hat"),
            float("E", 2.1e11),
            float("nu", 0.29),
            float("rho", 7850.0),
            float("alpha", 3.75),
        ],
    )
    .unwrap();
    assert_eq!(steel.parts, ["disc", "hat"]);
    assert_eq!(steel.name, "disc, hat");
    assert_eq!(
        steel.law,
        ElasticLaw::Isotropic {
            youngs_modulus: 2.1e11,
            poisson_ratio: 0.29
        }
    );
    assert_eq!(
        (steel.density, steel.alpha, steel.beta),
        (7850.0, 3.75, 0.0)
    );

    let lining = run(
        &TransverselyIsotropic,
        &[
            text("parts", "pad"),
            float("E", 5e9),
            float("nu", 0.2),
            float("E_3", 2e9),
            float("nu_13", 0.1),
            float("G_13", 0.9e9),
            text("normal", "0, 1, 0"),
            float("rho", 2500.0),
        ],
    )
    .unwrap();
    assert_eq!(
        lining.law,
        ElasticLaw::Orthotropic {
            constants: EngineeringConstants::transversely_isotropic((5e9, 0.2), 2e9, 0.1, 0.9e9),
            frame: Frame::Normal {
                axis3: [0.0, 1.0, 0.0]
            },
        }
    );

    let ring = run(
        &Orthotropic,
        &orthotropic(&[text("frame", "cylindrical"), text("origin", "0.1, 0, 0")]),
    )
    .unwrap();
    let ElasticLaw::Orthotropic { frame, .. } = ring.law else {
        panic!("orthotropic")
    };
    assert_eq!(
        frame,
        Frame::Cylindrical {
            origin: [0.1, 0.0, 0.0],
            axis: [0.0, 0.0, 1.0]
        }
    );
}

#[test]
fn a_frame_vector_the_frame_ignores_is_refused() {
    let error = |values: &[(&'static str, Value)]| {
        run(&Orthotropic, &orthotropic(values)).unwrap_err().message
    };
    assert_eq!(
        error(&[text("axis_3", "1, 0, 0")]),
        "`axis_3` is not used by the `global` frame: remove it, or choose the frame that uses it"
    );
    assert_eq!(
        error(&[text("frame", "cylindrical"), text("axis_1", "0, 1, 0")]),
        "`axis_1` is not used by the `cylindrical` frame: remove it, or choose the frame that uses it"
    );
    assert_eq!(
        error(&[text("frame", "axes"), text("origin", "0, 1, 0")]),
        "`origin` is not used by the `axes` frame: remove it, or choose the frame that uses it"
    );
    assert!(
        run(
            &Orthotropic,
            &orthotropic(&[text("frame", "axes"), text("axis_1", "0, 1, 0")])
        )
        .is_ok()
    );
}

#[test]
fn no_parts_and_constants_that_are_no_material_are_refused() {
    let steel = |parts: &str, nu: f64| {
        run(
            &Isotropic,
            &[
                text("parts", parts),
                float("E", 2.1e11),
                float("nu", nu),
                float("rho", 7850.0),
            ],
        )
    };
    assert_eq!(
        steel("", 0.3).unwrap_err().message,
        "`parts` is empty: name the mesh's parts made of this material"
    );
    assert_eq!(
        steel("disc", 0.5).unwrap_err().message,
        "material `disc`: nu = 0.5: Poisson's ratio must lie in (-1, 0.5)"
    );
    // ν_13 = 1.9 > √(E_1/E_3) = √3: S is not positive definite.
    let message = run(&Orthotropic, &orthotropic(&[float("nu_13", 1.9)]))
        .unwrap_err()
        .message;
    assert!(
        message.starts_with("material `pad`: E = [9000000000.0, 7000000000.0, 3000000000.0] Pa"),
        "{message}"
    );
    let message = run(
        &Orthotropic,
        &orthotropic(&[text("frame", "axes"), text("axis_1", "0, 0, 2")]),
    )
    .unwrap_err()
    .message;
    assert!(message.contains("is parallel to axis 3"), "{message}");
}

//! Anisotropic materials through assembly: the axial frequency of an orthotropic bar along
//! each material axis against rod theory; a rotated body with its rotated material frame
//! rings as before; transversely isotropic and cylindrical constants that are isotropic give
//! the isotropic stiffness. The values and their sources are in
//! `reference_values/anisotropy.json`.

use serde::Deserialize;
use squeal_stages::artifact::material::{ElasticLaw, EngineeringConstants, Frame, Material};
use squeal_stages::artifact::{ElementKind, Mesh, Model};
use squeal_stages::assemble::assemble_with;

use crate::element_convergence::block_of;
use crate::real_modes::{check_residuals_and_normalisation, frequencies_hz, lowest};
use crate::reference;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Case {
    length_m: f64,
    side_m: f64,
    cells: [usize; 3],
    youngs_moduli_pa: [f64; 3],
    poisson_ratios: [f64; 3],
    shear_moduli_pa: [f64; 3],
    density_kg_m3: f64,
    axial_tolerance: f64,
    n_rotated_frequencies: usize,
    rotation_tolerance: f64,
    unturned_frame_difference: f64,
    isotropic_tolerance: f64,
}

impl Case {
    fn constants(&self) -> EngineeringConstants {
        EngineeringConstants {
            youngs_moduli: self.youngs_moduli_pa,
            poisson_ratios: self.poisson_ratios,
            shear_moduli: self.shear_moduli_pa,
        }
    }

    fn material(&self, law: ElasticLaw) -> Material {
        Material {
            name: "lining".into(),
            parts: vec!["disc".into()],
            law,
            density: self.density_kg_m3,
            alpha: 0.0,
            beta: 0.0,
        }
    }

    fn bar(&self, kind: ElementKind) -> Mesh {
        let side = self.side_m;
        block_of(kind, [self.length_m, side, side], self.cells)
    }
}

fn assemble(mesh: &Mesh, material: &Material) -> Model {
    assemble_with(mesh, &[], std::slice::from_ref(material))
        .expect("assembly")
        .0
}

/// The share of a mode's displacement along x: near 1 for an axial mode of a bar along x.
fn axial_share(model: &Model, shape: &[f64]) -> f64 {
    let (mut along, mut all) = (0.0, 0.0);
    for dofs in &model.dof_of_node {
        for (axis, dof) in dofs.iter().enumerate() {
            if let Some(dof) = dof {
                let value = shape[*dof as usize].powi(2);
                all += value;
                if axis == 0 {
                    along += value;
                }
            }
        }
    }
    along / all
}

#[test]
fn an_orthotropic_bar_rings_axially_at_the_modulus_along_it() {
    let case: Case = reference::load("anisotropy");
    let mesh = case.bar(ElementKind::Hex20);
    let (x, y, z) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
    // Axis 1, then axis 2 (= axis 3 × axis 1 = z × y = −x), then axis 3 along the bar.
    for (axis, axis1, axis3) in [(0, x, z), (1, y, z), (2, y, x)] {
        let frame = Frame::Axes { axis1, axis3 };
        let law = ElasticLaw::Orthotropic {
            constants: case.constants(),
            frame,
        };
        let model = assemble(&mesh, &case.material(law));
        let solution = lowest(&model, 24);
        check_residuals_and_normalisation(&model, &solution);
        let frequencies = frequencies_hz(&solution);
        let axial = (6..frequencies.len())
            .find(|&mode| {
                let shape: Vec<f64> = solution.shapes.col(mode).iter().copied().collect();
                axial_share(&model, &shape) > 0.9
            })
            .unwrap_or_else(|| panic!("axis {}: no axial mode in {frequencies:?}", axis + 1));
        let expected =
            (case.youngs_moduli_pa[axis] / case.density_kg_m3).sqrt() / (2.0 * case.length_m);
        let error = (frequencies[axial] - expected).abs() / expected;
        assert!(
            error < case.axial_tolerance,
            "axis {} along the bar: {} Hz against {expected} Hz ({error:.1e})",
            axis + 1,
            frequencies[axial]
        );
    }
}

/// A rotation by three angles (about z, then x, then z).
fn rotation(a: f64, b: f64, c: f64) -> [[f64; 3]; 3] {
    let rz = |t: f64| {
        [
            [t.cos(), -t.sin(), 0.0],
            [t.sin(), t.cos(), 0.0],
            [0.0, 0.0, 1.0],
        ]
    };
    let rx = |t: f64| {
        [
            [1.0, 0.0, 0.0],
            [0.0, t.cos(), -t.sin()],
            [0.0, t.sin(), t.cos()],
        ]
    };
    let product = |p: [[f64; 3]; 3], q: [[f64; 3]; 3]| {
        let mut r = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                r[i][j] = (0..3).map(|k| p[i][k] * q[k][j]).sum();
            }
        }
        r
    };
    product(rz(c), product(rx(b), rz(a)))
}

fn turn(R: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| (0..3).map(|j| R[i][j] * v[j]).sum())
}

fn turn_frame(R: &[[f64; 3]; 3], frame: Frame) -> Frame {
    match frame {
        Frame::Axes { axis1, axis3 } => Frame::Axes {
            axis1: turn(R, axis1),
            axis3: turn(R, axis3),
        },
        Frame::Cylindrical { origin, axis } => Frame::Cylindrical {
            origin: turn(R, origin),
            axis: turn(R, axis),
        },
        other => panic!("not turned here: {other:?}"),
    }
}

fn elastic_frequencies(model: &Model, n: usize) -> Vec<f64> {
    let solution = lowest(model, 6 + n);
    check_residuals_and_normalisation(model, &solution);
    frequencies_hz(&solution)[6..].to_vec()
}

fn largest_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(a, b)| (a - b).abs() / b)
        .fold(0.0, f64::max)
}

#[test]
fn a_body_turned_with_its_material_frame_rings_as_before() {
    let case: Case = reference::load("anisotropy");
    let n = case.n_rotated_frequencies;
    let mesh = block_of(
        ElementKind::Tet10,
        [case.length_m, case.side_m, case.side_m],
        [8, 2, 2],
    );
    let R = rotation(0.7, 1.1, -0.4);
    let mut turned = mesh.clone();
    for node in &mut turned.nodes {
        *node = turn(&R, *node);
    }
    let frames = [
        Frame::Axes {
            axis1: [1.0, 0.3, 0.0],
            axis3: [0.2, -0.4, 1.0],
        },
        // An axis beside the bar: the axes vary from element to element.
        Frame::Cylindrical {
            origin: [0.1, -0.15, 0.0],
            axis: [0.0, 0.2, 1.0],
        },
    ];
    for frame in frames {
        let law = |frame| ElasticLaw::Orthotropic {
            constants: case.constants(),
            frame,
        };
        let before = elastic_frequencies(&assemble(&mesh, &case.material(law(frame))), n);
        let after = elastic_frequencies(
            &assemble(&turned, &case.material(law(turn_frame(&R, frame)))),
            n,
        );
        let difference = largest_difference(&after, &before);
        assert!(
            difference < case.rotation_tolerance,
            "{frame:?}: turned {after:?} against {before:?} ({difference:.1e})"
        );
        // The frame matters: the body turned alone, its material left behind, rings otherwise.
        let alone = elastic_frequencies(&assemble(&turned, &case.material(law(frame))), n);
        assert!(
            largest_difference(&alone, &before) > case.unturned_frame_difference,
            "{frame:?}: the frame changed nothing: {alone:?} against {before:?}"
        );
    }
}

#[test]
fn transversely_isotropic_or_cylindrical_constants_that_are_isotropic_give_the_isotropic_law() {
    let case: Case = reference::load("anisotropy");
    let mesh = case.bar(ElementKind::Wedge15);
    let (E, nu) = (case.youngs_moduli_pa[0], case.poisson_ratios[0]);
    let isotropic = assemble(
        &mesh,
        &case.material(ElasticLaw::Isotropic {
            youngs_modulus: E,
            poisson_ratio: nu,
        }),
    );
    let shear = E / (2.0 * (1.0 + nu));
    let laws = [
        ElasticLaw::Orthotropic {
            constants: EngineeringConstants::transversely_isotropic((E, nu), E, nu, shear),
            frame: Frame::Normal {
                axis3: [0.3, -0.5, 0.8],
            },
        },
        ElasticLaw::Orthotropic {
            constants: EngineeringConstants::isotropic(E, nu),
            frame: Frame::Cylindrical {
                origin: [0.0, 0.1, 0.0],
                axis: [1.0, 0.0, 1.0],
            },
        },
    ];
    let scale = isotropic
        .K
        .values
        .iter()
        .fold(0.0_f64, |m, v| m.max(v.abs()));
    for law in laws {
        let model = assemble(&mesh, &case.material(law));
        assert_eq!(model.K.col_ptr, isotropic.K.col_ptr);
        assert_eq!(model.K.row_idx, isotropic.K.row_idx);
        let worst = model
            .K
            .values
            .iter()
            .zip(&isotropic.K.values)
            .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(
            worst < case.isotropic_tolerance * scale,
            "{law:?}: K differs by {:.1e} of its largest entry",
            worst / scale
        );
        assert_eq!(
            model.M, isotropic.M,
            "{law:?}: the mass does not depend on the law"
        );
    }
}

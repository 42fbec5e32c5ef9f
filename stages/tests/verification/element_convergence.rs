//! Convergence of every element kind: the first bending frequency of a free stubby beam under
//! uniform refinement, the observed order against finite-element theory; a free annular disc
//! in 10-node tetrahedra against 20-node hexahedra; and the frequencies of a second-order
//! mesh against an independent finite-element code on the same mesh.

use serde::Deserialize;
use squeal_stages::artifact::{ElementKind, Mesh};
use squeal_stages::assemble::with_default_materials;
use squeal_stages::mesh::{convert, structured};

use crate::real_modes::{check_residuals_and_normalisation, frequencies_hz, lowest};
use crate::reference;

/// A structured block of hexahedra as elements of `kind` (split, then mid-edge nodes).
pub fn block_of(kind: ElementKind, lengths: [f64; 3], counts: [usize; 3]) -> Mesh {
    convert::as_kind(&structured::block(lengths, counts, "disc"), kind)
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Orders {
    length_m: f64,
    side_m: f64,
    /// Hexahedral cells (along, across, across) of the coarsest mesh; each next mesh halves h.
    coarsest: [usize; 3],
    n_meshes: usize,
    /// Expected order of the frequency error, by kind name.
    expected: std::collections::BTreeMap<String, f64>,
    order_tolerance: f64,
    /// Largest relative difference between the second-order kinds on the finest mesh.
    second_order_agreement: f64,
}

#[test]
fn every_kind_converges_at_its_order_on_a_free_beam() {
    let case: Orders = reference::load("element_orders");
    let mut finest = Vec::new();
    for kind in ElementKind::ALL {
        let frequencies: Vec<f64> = (0..case.n_meshes)
            .map(|level| {
                let counts = case.coarsest.map(|n| n << level);
                let mesh = block_of(kind, [case.length_m, case.side_m, case.side_m], counts);
                let (model, _) = with_default_materials(&mesh, "", &[]).expect("assembly");
                let solution = lowest(&model, 8);
                check_residuals_and_normalisation(&model, &solution);
                // Six rigid-body modes, then the first bending pair.
                frequencies_hz(&solution)[6]
            })
            .collect();
        // Observed order from three successive meshes: p = log2(|f_h − f_h/2| / |f_h/2 − f_h/4|).
        let orders: Vec<f64> = frequencies
            .windows(3)
            .map(|f| ((f[0] - f[1]).abs() / (f[1] - f[2]).abs()).log2())
            .collect();
        let observed = *orders.last().expect("three meshes at least");
        let expected = case.expected[kind.name()];
        assert!(
            (observed - expected).abs() < case.order_tolerance
                && (observed - expected).abs() < (orders[0] - expected).abs(),
            "{kind}: orders {orders:?} should approach {expected} (frequencies {frequencies:?})"
        );
        if kind.n_nodes() > kind.n_corners() {
            finest.push((kind, *frequencies.last().expect("meshes")));
        }
    }
    let (_, first) = finest[0];
    for (kind, frequency) in &finest {
        let difference = (frequency - first).abs() / first;
        assert!(
            difference < case.second_order_agreement,
            "{kind}: {frequency} Hz against {first} Hz"
        );
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct IndependentCode {
    /// The mesh file, in `model/tests/data/elements/`, of first-order elements that squeal
    /// makes second-order with [`convert::with_mid_edge_nodes`].
    mesh: String,
    /// The elastic frequencies the independent code computes on it (Hz), after the six
    /// rigid-body modes.
    frequencies_hz: Vec<f64>,
    /// |f − f_independent| / f_independent.
    tolerance: f64,
}

#[test]
fn a_second_order_mesh_gives_the_frequencies_of_an_independent_code() {
    for case in ["scikit_fem_tet10", "scikit_fem_vented_disc"] {
        let case: IndependentCode = reference::load(case);
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../model/tests/data/elements")
            .join(&case.mesh);
        let text = std::fs::read_to_string(&path).expect("the test mesh");
        let linear = squeal_stages::mesh::gmsh::read_msh(&text, &Default::default()).expect("read");
        let mesh = convert::with_mid_edge_nodes(&linear);
        let (model, _) = with_default_materials(&mesh, "", &[]).expect("assembly");
        let solution = lowest(&model, 6 + case.frequencies_hz.len());
        check_residuals_and_normalisation(&model, &solution);
        let frequencies = frequencies_hz(&solution);
        for (mode, (got, want)) in frequencies[6..]
            .iter()
            .zip(&case.frequencies_hz)
            .enumerate()
        {
            assert!(
                (got - want).abs() < case.tolerance * want,
                "{}: elastic mode {mode}: {got} Hz against {want} Hz",
                case.mesh
            );
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FreeDisc {
    inner_radius_m: f64,
    outer_radius_m: f64,
    thickness_m: f64,
    /// Hexahedral cells: radial, around, through the thickness.
    cells: [usize; 3],
    n_frequencies: usize,
    /// Largest |f_tet10 − f_hex20| / f_hex20 over the frequencies.
    tolerance: f64,
    /// A coarser mesh (half the cells each way) and a finer one in hex20, the reference.
    coarse_cells: [usize; 3],
    reference_cells: [usize; 3],
    /// Largest |f − f_reference| / f_reference on `cells`, for each kind.
    reference_tolerance: f64,
}

#[test]
fn a_free_annular_disc_rings_alike_in_10_node_tetrahedra_and_20_node_hexahedra() {
    let case: FreeDisc = reference::load("free_disc_tet10_hex20");
    let frequencies = |kind: ElementKind, cells: [usize; 3]| -> Vec<f64> {
        let hexes = structured::annulus(
            case.inner_radius_m,
            case.outer_radius_m,
            0.0,
            case.thickness_m,
            cells,
            "disc",
        );
        let mesh = convert::as_kind(&hexes, kind);
        let (model, _) = with_default_materials(&mesh, "", &[]).expect("assembly");
        let solution = lowest(&model, 6 + case.n_frequencies);
        check_residuals_and_normalisation(&model, &solution);
        frequencies_hz(&solution)[6..].to_vec()
    };
    let largest_difference = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .map(|(a, b)| (a - b).abs() / b)
            .fold(0.0, f64::max)
    };
    let (tet10, hex20) = (
        frequencies(ElementKind::Tet10, case.cells),
        frequencies(ElementKind::Hex20, case.cells),
    );
    let worst = largest_difference(&tet10, &hex20);
    assert!(
        worst < case.tolerance,
        "tet10 {tet10:?} against hex20 {hex20:?}"
    );
    // Both converge to the reference: each is closer to it than on the coarser mesh.
    let reference = frequencies(ElementKind::Hex20, case.reference_cells);
    for (kind, on_cells) in [(ElementKind::Tet10, &tet10), (ElementKind::Hex20, &hex20)] {
        let coarse = largest_difference(&frequencies(kind, case.coarse_cells), &reference);
        let finer = largest_difference(on_cells, &reference);
        assert!(
            finer < case.reference_tolerance && finer < coarse,
            "{kind}: {finer:e} from the reference on {:?}, {coarse:e} on {:?}",
            case.cells,
            case.coarse_cells
        );
    }
}

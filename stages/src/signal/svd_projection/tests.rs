use std::sync::Arc;

use super::*;
use crate::stage::{Input, Value};

/// A deterministic pseudo-random stream in [−0.5, 0.5).
struct Noise(u64);

impl Noise {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }
}

/// A tridiagonal SPD mass matrix (a consistent 1D bar mass), as COO with both triangles.
fn bar_mass(n: usize) -> (Vec<i64>, Vec<i64>, Vec<f64>) {
    let (mut rows, mut cols, mut values) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..n {
        rows.push(i as i64);
        cols.push(i as i64);
        values.push(4.0 + 0.1 * i as f64);
        if i + 1 < n {
            for (r, c) in [(i, i + 1), (i + 1, i)] {
                rows.push(r as i64);
                cols.push(c as i64);
                values.push(1.0);
            }
        }
    }
    (rows, cols, values)
}

fn mass_matrix(n: usize) -> MassMatrix {
    let (rows, cols, values) = bar_mass(n);
    MassMatrix::from_triplets(&rows, &cols, &values, n).unwrap()
}

fn max_abs(matrix: &Mat<f64>) -> f64 {
    let mut largest = 0.0f64;
    for j in 0..matrix.ncols() {
        for i in 0..matrix.nrows() {
            largest = largest.max(matrix[(i, j)].abs());
        }
    }
    largest
}

#[test]
fn mass_svd_reconstructs_and_is_mass_orthonormal() {
    // Tolerance: 1e-13 relative (round-off) for X − Ψ Σ Vᵀ, ΨᵀMΨ − I and VᵀV − I.
    let (n, m) = (60, 12);
    let mut noise = Noise(7);
    let x = Mat::from_fn(n, m, |_, _| noise.next());
    let mass = mass_matrix(n);
    let svd = mass_svd(&x, &mass).unwrap();
    let sigma = Mat::from_fn(
        m,
        m,
        |i, j| if i == j { svd.singular_values[i] } else { 0.0 },
    );
    let reconstructed = svd.shapes.as_ref() * sigma.as_ref() * svd.right.transpose();
    let error = max_abs(&(&reconstructed - &x)) / max_abs(&x);
    assert!(error < 1e-13, "reconstruction {error:e}");
    let gram = svd.shapes.transpose() * mass.apply_columns(&svd.shapes).as_ref();
    let orthogonality = max_abs(&(&gram - Mat::<f64>::identity(m, m)));
    assert!(orthogonality < 1e-13, "ΨᵀMΨ − I = {orthogonality:e}");
    let right_gram = svd.right.transpose() * svd.right.as_ref();
    assert!(max_abs(&(&right_gram - Mat::<f64>::identity(m, m))) < 1e-13);
    assert!(
        svd.singular_values
            .windows(2)
            .all(|pair| pair[0] >= pair[1]),
        "{:?}",
        svd.singular_values
    );
}

#[test]
fn diagonal_and_sparse_masses_agree() {
    // A diagonal mass given both ways: same singular values to 1e-13 relative.
    let (n, m) = (30, 5);
    let mut noise = Noise(11);
    let x = Mat::from_fn(n, m, |_, _| noise.next());
    let diagonal: Vec<f64> = (0..n).map(|i| 1.0 + i as f64).collect();
    let index: Vec<i64> = (0..n as i64).collect();
    let sparse = MassMatrix::from_triplets(&index, &index, &diagonal, n).unwrap();
    let a = mass_svd(&x, &MassMatrix::Diagonal(diagonal)).unwrap();
    let b = mass_svd(&x, &sparse).unwrap();
    for (sa, sb) in a.singular_values.iter().zip(&b.singular_values) {
        assert!((sa - sb).abs() <= 1e-13 * a.singular_values[0]);
    }
}

/// Complex modes whose real and imaginary parts, over all modes, are M-orthonormal up to
/// a factor 1/√2 (so each mode has ‖φ‖_M = 1): Gram–Schmidt of random vectors.
fn orthogonal_modes(n: usize, n_modes: usize, mass: &MassMatrix) -> Mat<f64> {
    let mut noise = Noise(3);
    let random = Mat::from_fn(n, 2 * n_modes, |_, _| noise.next());
    let svd = mass_svd(&random, mass).unwrap();
    Mat::from_fn(n, 2 * n_modes, |i, j| {
        svd.shapes[(i, j)] / std::f64::consts::SQRT_2
    })
}

fn modes_tables(parts: &Mat<f64>, freqs: &[f64]) -> (Table, Table) {
    let mut modes = Table::new();
    for mode in 0..freqs.len() {
        modes = modes
            .with(
                format!("mode_{:04}_re", mode + 1),
                parts.col_as_slice(2 * mode).to_vec(),
            )
            .with(
                format!("mode_{:04}_im", mode + 1),
                parts.col_as_slice(2 * mode + 1).to_vec(),
            );
    }
    let frequencies = Table::new()
        .with("mode", (1..=freqs.len() as i64).collect::<Vec<i64>>())
        .with("freq_hz", freqs.to_vec());
    (modes, frequencies)
}

fn run(
    snapshots: Table,
    modes: Table,
    frequencies: Table,
    mass: Table,
    n_shapes: i64,
) -> Result<Outputs, StageError> {
    let one = |table: Table| Input::One(Arc::new(Artifact::Table(table)));
    let inputs = Inputs(BTreeMap::from([
        ("snapshots".to_string(), one(snapshots)),
        ("modes".to_string(), one(modes)),
        ("frequencies".to_string(), one(frequencies)),
        ("mass".to_string(), one(mass)),
    ]));
    let params = Params(BTreeMap::from([
        ("n_last_snapshots".into(), Value::Int(0)),
        ("n_shapes".into(), Value::Int(n_shapes)),
    ]));
    SvdProjection.run(&params, &inputs)
}

#[test]
fn limit_cycle_of_two_modes_projects_on_exactly_those_two() {
    // Snapshots of Re(c₁ φ₂ e^{iω₁t} + c₂ φ₅ e^{iω₂t}): four nonzero principal values; each
    // of the four shapes has coefficients on modes 2 and 5 only (others < 1e-12), with
    // |c₂|² + |c₅|² = 1/2 to 1e-12 (module doc).
    let (n, n_modes) = (40, 6);
    let mass = mass_matrix(n);
    let parts = orthogonal_modes(n, n_modes, &mass);
    let freqs = [900.0, 3537.0, 5200.0, 8000.0, 11_100.0, 14_000.0];
    let (modes, frequencies) = modes_tables(&parts, &freqs);
    let mut snapshots = Table::new();
    for step in 0..50 {
        let t = step as f64 * 1.3e-5;
        let (w1, w2) = (
            2.0 * std::f64::consts::PI * freqs[1],
            2.0 * std::f64::consts::PI * freqs[4],
        );
        let column: Vec<f64> = (0..n)
            .map(|i| {
                // Re((re + i im) e^{iωt}) = re cos ωt − im sin ωt
                1.0 * (parts[(i, 2)] * (w1 * t).cos() - parts[(i, 3)] * (w1 * t).sin())
                    + 0.3
                        * (parts[(i, 8)] * (w2 * t + 0.4).cos()
                            - parts[(i, 9)] * (w2 * t + 0.4).sin())
            })
            .collect();
        snapshots = snapshots.with(format!("u_{step:03}"), column);
    }
    let (rows, cols, values) = bar_mass(n);
    let mass_table = Table::new()
        .with("row", rows)
        .with("col", cols)
        .with("value", values);
    let outputs = run(snapshots, modes, frequencies, mass_table, 4).unwrap();

    let principal = outputs["principal"].as_table().unwrap();
    let Some(ColumnData::F64(singular_values)) = principal.column("singular_value") else {
        panic!()
    };
    assert!(
        singular_values[3] > 1e-3 * singular_values[0],
        "{singular_values:?}"
    );
    assert!(
        singular_values[4] < 1e-12 * singular_values[0],
        "{singular_values:?}"
    );

    let projection = outputs["projection"].as_table().unwrap();
    let (
        Some(ColumnData::I64(shape)),
        Some(ColumnData::I64(mode)),
        Some(ColumnData::F64(coefficient)),
    ) = (
        projection.column("shape"),
        projection.column("mode"),
        projection.column("coefficient"),
    )
    else {
        panic!()
    };
    assert_eq!(coefficient.len(), 4 * n_modes);
    for shape_number in 1..=4 {
        let mut in_plane = 0.0;
        for row in (0..shape.len()).filter(|&row| shape[row] == shape_number) {
            if mode[row] == 2 || mode[row] == 5 {
                in_plane += coefficient[row] * coefficient[row];
            } else {
                assert!(
                    coefficient[row] < 1e-12,
                    "shape {shape_number} mode {}: {}",
                    mode[row],
                    coefficient[row]
                );
            }
        }
        assert!(
            (in_plane - 0.5).abs() < 1e-12,
            "shape {shape_number}: Σ|c|² = {in_plane}"
        );
    }
    let Artifact::Figure(figure) = &outputs["projection_figure"] else {
        panic!()
    };
    assert!(figure.svg.contains("principal shapes"));
    assert_eq!(outputs["shapes"].as_table().unwrap().columns().len(), 4);
}

#[test]
fn bad_mass_matrices_are_refused() {
    let err = MassMatrix::from_triplets(&[0, 1], &[1, 0], &[1.0, 2.0], 2).unwrap_err();
    assert!(err.message.contains("not symmetric, M[0, 1] = 1"), "{err}");
    let err = MassMatrix::from_triplets(&[0, 5], &[0, 5], &[1.0, 1.0], 3).unwrap_err();
    assert!(err.message.contains("entry 1 at (5, 5)"), "{err}");
    let indefinite = MassMatrix::Diagonal(vec![1.0, -1.0]);
    let x = Mat::from_fn(2, 1, |i, _| i as f64);
    let err = mass_svd(&x, &indefinite).err().unwrap();
    assert!(err.message.contains("not positive definite"), "{err}");
    let err =
        MassMatrix::from_table(&Table::new().with("diagonal", vec![1.0, 0.0]), 2).unwrap_err();
    assert!(err.message.contains("diagonal entry 1 is 0"), "{err}");
}

#[test]
fn duplicate_triplets_add_up() {
    let mass = MassMatrix::from_triplets(&[0, 0, 1], &[0, 0, 1], &[1.0, 2.0, 5.0], 2).unwrap();
    let mut out = [0.0; 2];
    mass.apply(&[1.0, 1.0], &mut out);
    assert_eq!(out, [3.0, 5.0]);
}

#[test]
fn a_mode_without_frequency_is_named() {
    let modes = Table::new()
        .with("mode_0003_re", vec![1.0])
        .with("mode_0003_im", vec![0.0]);
    let frequencies = Table::new()
        .with("mode", vec![1i64])
        .with("freq_hz", vec![10.0]);
    let err = ComplexModes::from_tables(&modes, &frequencies)
        .err()
        .unwrap();
    assert!(err.message.contains("no row for mode 3"), "{err}");
}

use std::sync::Arc;

use super::*;
use crate::artifact::{ComplexMode, ComplexShape};
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

/// Complex modes at `freqs` (neutral: λ = iω), shape k from columns 2k and 2k + 1 of `parts`.
fn complex_modes(parts: &Mat<f64>, freqs: &[f64]) -> ComplexModes {
    ComplexModes {
        modes: freqs
            .iter()
            .enumerate()
            .map(|(mode, freq)| ComplexMode {
                number: mode as i64 + 1,
                re: 0.0,
                im: 2.0 * std::f64::consts::PI * freq,
                residual: 0.0,
                condition: f64::NAN,
                shape: Some(ComplexShape {
                    re: parts.col_as_slice(2 * mode).to_vec(),
                    im: parts.col_as_slice(2 * mode + 1).to_vec(),
                }),
            })
            .collect(),
    }
}

fn run(
    snapshots: Table,
    modes: ComplexModes,
    mass: Table,
    n_shapes: i64,
) -> Result<Outputs, StageError> {
    let one = |artifact: Artifact| Input::One(Arc::new(artifact));
    let inputs = Inputs(BTreeMap::from([
        ("snapshots".to_string(), one(Artifact::Table(snapshots))),
        (
            "complex_modes".to_string(),
            one(Artifact::ComplexModes(Box::new(modes))),
        ),
        ("mass".to_string(), one(Artifact::Table(mass))),
    ]));
    let params = Params(BTreeMap::from([
        ("n_last_snapshots".into(), Value::Int(0)),
        ("n_shapes".into(), Value::Int(n_shapes)),
    ]));
    SvdProjection.run(&params, &inputs)
}

/// Snapshots of Re(c₁ φ₂ e^{iω₁t} + c₂ φ₅ e^{iω₂t}) over the DOFs of `parts`, as rows of a
/// nodal table where `clamped` rows (each before the DOF of its number) hold zeros and a
/// `dof` of −1; the bar mass on the DOFs, 1 on the clamped rows.
fn limit_cycle(parts: &Mat<f64>, freqs: &[f64], clamped: &[usize]) -> (Table, Table) {
    let n = parts.nrows();
    let mut dof_of_row: Vec<Option<usize>> = Vec::new();
    for dof in 0..n {
        if clamped.contains(&dof) {
            dof_of_row.push(None);
        }
        dof_of_row.push(Some(dof));
    }
    let row_of_dof: Vec<usize> = (0..dof_of_row.len())
        .filter(|&row| dof_of_row[row].is_some())
        .collect();
    let mut snapshots = Table::new().with(
        "dof",
        dof_of_row
            .iter()
            .map(|dof| dof.map_or(-1, |dof| dof as i64))
            .collect::<Vec<i64>>(),
    );
    let (w1, w2) = (
        2.0 * std::f64::consts::PI * freqs[1],
        2.0 * std::f64::consts::PI * freqs[4],
    );
    for step in 0..50 {
        let t = step as f64 * 1.3e-5;
        let column: Vec<f64> = dof_of_row
            .iter()
            .map(|dof| {
                let Some(i) = *dof else { return 0.0 };
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
    let map = |dofs: Vec<i64>| -> Vec<i64> {
        dofs.iter()
            .map(|&dof| row_of_dof[dof as usize] as i64)
            .collect()
    };
    let (mut rows, mut cols, mut values) = (map(rows), map(cols), values);
    for row in (0..dof_of_row.len()).filter(|&row| dof_of_row[row].is_none()) {
        rows.push(row as i64);
        cols.push(row as i64);
        values.push(1.0);
    }
    let mass = Table::new()
        .with("row", rows)
        .with("col", cols)
        .with("value", values);
    (snapshots, mass)
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
    let (snapshots, mass) = limit_cycle(&parts, &freqs, &[]);
    let outputs = run(snapshots, complex_modes(&parts, &freqs), mass, 4).unwrap();

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
fn clamped_rows_of_a_nodal_table_take_zeros_of_the_modes() {
    // The same limit cycle with four clamped rows (zero snapshots, unit mass): the modes are
    // over the 40 DOFs and laid on the snapshot rows by their `dof` column; the projection is
    // the same to 1e-12, and modes of another model are refused.
    let (n, n_modes) = (40, 6);
    let parts = orthogonal_modes(n, n_modes, &mass_matrix(n));
    let freqs = [900.0, 3537.0, 5200.0, 8000.0, 11_100.0, 14_000.0];
    let coefficients = |clamped: &[usize]| -> Vec<f64> {
        let (snapshots, mass) = limit_cycle(&parts, &freqs, clamped);
        let outputs = run(snapshots, complex_modes(&parts, &freqs), mass, 4).unwrap();
        outputs["projection"]
            .as_table()
            .unwrap()
            .f64("coefficient")
            .unwrap()
            .to_vec()
    };
    let free = coefficients(&[]);
    let clamped = coefficients(&[0, 7, 8, 39]);
    assert_eq!(free.len(), clamped.len());
    for (a, b) in free.iter().zip(&clamped) {
        assert!((a - b).abs() < 1e-12, "{a} against {b}");
    }

    let (snapshots, mass) = limit_cycle(&parts, &freqs, &[]);
    let short = Mat::from_fn(n - 1, 2 * n_modes, |i, j| parts[(i, j)]);
    let err = run(snapshots, complex_modes(&short, &freqs), mass, 4).unwrap_err();
    assert!(
        err.message
            .contains("mode 1 has 39 DOFs, DOF 39 was asked for"),
        "{err}"
    );
}

//! `svd_projection`: principal shapes of a set of snapshots in the mass inner product, and their
//! projection on the complex modes (which modes a limit cycle is made of; `docs/science.md` §7).
//!
//! # Mass-weighted SVD
//!
//! With snapshots as columns, `X` (n DOFs × m snapshots), and the mass matrix `M` (symmetric
//! positive definite, sparse), the SVD in the mass inner product `⟨u, v⟩_M = uᵀ M v` is
//!
//! ```text
//! X = Ψ Σ Vᵀ,    Ψᵀ M Ψ = I,    Vᵀ V = I,    σ₁ ≥ σ₂ ≥ … ≥ 0
//! ```
//!
//! It is computed without factorising `M` (whose Cholesky factor of a 3D mesh fills in): an
//! M-orthonormal basis `Q` of the snapshots by classical Gram–Schmidt in the M inner product,
//! run twice per column ("twice is enough": orthogonality to round-off), gives `X = Q R`
//! with `Qᵀ M Q = I` and `R` small (m × m, upper triangular). The dense SVD `R = U Σ Vᵀ`
//! (faer) then gives `Ψ = Q U`. This needs one sparse product `M w` per snapshot. Each shape's
//! sign is fixed so that its largest component is positive. `energy_fraction = σ_k² / Σ σ²`:
//! the share of `‖X‖²_M` (the kinetic-energy-like norm of the snapshots) the shape carries.
//!
//! # Projection on the complex modes
//!
//! For a complex mode `φ = φ_re + i φ_im` and a principal shape `ψ` (M-unit):
//!
//! ```text
//! coefficient = |⟨φ, ψ⟩_M| / ‖φ‖_M = |φᴴ M ψ| / √(φᴴ M φ)
//! ```
//!
//! a number in [0, 1] that does not depend on how the modes were normalised. A real shape
//! lying in the plane of a mode whose real and imaginary parts are M-orthogonal with equal
//! norms scores `1/√2`: a real vector is half `φ`, half its conjugate `φ̄`. Over a set of modes
//! that are M-orthogonal together with their conjugates, a shape's squared coefficients add up
//! to at most 1/2 (Bessel), with equality when it lies in their span.
//!
//! # Inputs
//!
//! - `snapshots`: wide table, one row per DOF, one f64 column per snapshot in time order
//!   (other columns are ignored). Its i64 column `dof`, when there is one, gives the model DOF
//!   of each row (−1 where clamped: the rows of the transient's nodal tables); without it, row
//!   `r` is DOF `r`.
//! - `complex_modes`: the stability stage's complex modes; those with a shape are projected on.
//! - `mass`: either COO triplets `row`, `col` (i64, 0-based DOFs) and `value` (f64) holding
//!   the full symmetric matrix (both triangles; duplicates add up, as in assembly), or a single
//!   f64 column `diagonal` (a lumped mass, one row per DOF).

use std::collections::BTreeMap;

use faer::Mat;
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::artifact::{Artifact, ArtifactType, ComplexModes, ShapeMatrices};
use crate::plot::{self, DrawResult, Drawing, drawing_error};
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError};
use crate::table::{ColumnData, Table};

/// Relative asymmetry of `M` tolerated (to the largest entry): values read back from text
/// files may differ in their last digits.
const SYMMETRY_TOLERANCE: f64 = 1e-9;

/// A symmetric positive definite mass matrix, sparse.
#[derive(Debug, Clone, PartialEq)]
pub enum MassMatrix {
    Diagonal(Vec<f64>),
    /// Compressed sparse rows, duplicates summed, columns sorted within each row.
    Sparse {
        row_starts: Vec<usize>,
        cols: Vec<usize>,
        values: Vec<f64>,
    },
}

impl MassMatrix {
    /// Reads either representation (module doc) for a model of `n_dofs` DOFs.
    pub fn from_table(table: &Table, n_dofs: usize) -> Result<MassMatrix, StageError> {
        if let (Some(rows), Some(cols), Some(values)) = (
            table.column("row"),
            table.column("col"),
            table.column("value"),
        ) {
            let (ColumnData::I64(rows), ColumnData::I64(cols), ColumnData::F64(values)) =
                (rows, cols, values)
            else {
                return Err(StageError::new(
                    "mass: `row` and `col` must be i64 and `value` f64",
                ));
            };
            return MassMatrix::from_triplets(rows, cols, values, n_dofs);
        }
        if let Some(column) = table.column("diagonal") {
            let ColumnData::F64(diagonal) = column else {
                return Err(StageError::new("mass: `diagonal` must be f64"));
            };
            if diagonal.len() != n_dofs {
                return Err(StageError::new(format!(
                    "mass: {} diagonal entries for {n_dofs} DOFs",
                    diagonal.len()
                )));
            }
            if let Some(row) = diagonal.iter().position(|&m| !(m > 0.0 && m.is_finite())) {
                return Err(StageError::new(format!(
                    "mass: diagonal entry {row} is {}, not positive",
                    diagonal[row]
                )));
            }
            return Ok(MassMatrix::Diagonal(diagonal.clone()));
        }
        Err(StageError::new(
            "mass: expected columns `row`, `col`, `value` (COO) or `diagonal`",
        ))
    }

    pub fn from_triplets(
        rows: &[i64],
        cols: &[i64],
        values: &[f64],
        n_dofs: usize,
    ) -> Result<MassMatrix, StageError> {
        let mut entries = Vec::with_capacity(values.len());
        for (idx, ((&row, &col), &value)) in rows.iter().zip(cols).zip(values).enumerate() {
            let in_range = |dof: i64| dof >= 0 && (dof as usize) < n_dofs;
            if !in_range(row) || !in_range(col) {
                return Err(StageError::new(format!(
                    "mass: entry {idx} at ({row}, {col}) is outside the {n_dofs} DOFs"
                )));
            }
            if !value.is_finite() {
                return Err(StageError::new(format!(
                    "mass: entry {idx} at ({row}, {col}) is {value}"
                )));
            }
            entries.push((row as usize, col as usize, value));
        }
        entries.sort_by_key(|&(row, col, _)| (row, col));
        let mut row_starts = vec![0; n_dofs + 1];
        let mut cols_out: Vec<usize> = Vec::with_capacity(entries.len());
        let mut values_out: Vec<f64> = Vec::with_capacity(entries.len());
        let mut previous = None;
        for (row, col, value) in entries {
            if previous == Some((row, col)) {
                *values_out.last_mut().expect("a previous entry") += value;
            } else {
                cols_out.push(col);
                values_out.push(value);
                row_starts[row + 1] += 1;
                previous = Some((row, col));
            }
        }
        for row in 0..n_dofs {
            row_starts[row + 1] += row_starts[row];
        }
        let matrix = MassMatrix::Sparse {
            row_starts,
            cols: cols_out,
            values: values_out,
        };
        matrix.check_symmetric()?;
        Ok(matrix)
    }

    fn check_symmetric(&self) -> Result<(), StageError> {
        let MassMatrix::Sparse {
            row_starts,
            cols,
            values,
        } = self
        else {
            return Ok(());
        };
        let largest = values.iter().map(|v| v.abs()).fold(0.0, f64::max);
        let entry = |row: usize, col: usize| -> f64 {
            let range = row_starts[row]..row_starts[row + 1];
            match cols[range.clone()].binary_search(&col) {
                Ok(offset) => values[range.start + offset],
                Err(_) => 0.0,
            }
        };
        for row in 0..row_starts.len() - 1 {
            for idx in row_starts[row]..row_starts[row + 1] {
                let col = cols[idx];
                let mirror = entry(col, row);
                if (values[idx] - mirror).abs() > SYMMETRY_TOLERANCE * largest {
                    return Err(StageError::new(format!(
                        "mass: not symmetric, M[{row}, {col}] = {} but M[{col}, {row}] = {mirror} (give both triangles)",
                        values[idx]
                    )));
                }
            }
        }
        Ok(())
    }

    /// `out = M x`.
    pub fn apply(&self, x: &[f64], out: &mut [f64]) {
        match self {
            MassMatrix::Diagonal(diagonal) => {
                for ((out, m), x) in out.iter_mut().zip(diagonal).zip(x) {
                    *out = m * x;
                }
            }
            MassMatrix::Sparse {
                row_starts,
                cols,
                values,
            } => {
                for (row, out) in out.iter_mut().enumerate() {
                    let range = row_starts[row]..row_starts[row + 1];
                    *out = cols[range.clone()]
                        .iter()
                        .zip(&values[range])
                        .map(|(&col, value)| value * x[col])
                        .sum();
                }
            }
        }
    }

    /// `M X`, column by column.
    pub fn apply_columns(&self, x: &Mat<f64>) -> Mat<f64> {
        let mut out = Mat::<f64>::zeros(x.nrows(), x.ncols());
        for col in 0..x.ncols() {
            self.apply(x.col_as_slice(col), out.col_as_slice_mut(col));
        }
        out
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(a, b)| a * b).sum()
}

/// The f64 columns of a wide snapshot table (one row per DOF) as the columns of a matrix, the
/// The model DOF of each row of a snapshot table: its `dof` column (−1: clamped), or the row.
fn dof_of_row(table: &Table) -> Result<Vec<Option<usize>>, StageError> {
    match table.column("dof") {
        None => Ok((0..table.n_rows()).map(Some).collect()),
        Some(ColumnData::I64(dofs)) => {
            Ok(dofs.iter().map(|&dof| usize::try_from(dof).ok()).collect())
        }
        Some(_) => Err(StageError::new("snapshots: the `dof` column is not i64")),
    }
}

/// last `n_last` of them (0: all); an error names an empty table or a value that is not finite.
pub fn snapshot_matrix(table: &Table, n_last: usize) -> Result<Mat<f64>, StageError> {
    let mut columns: Vec<(&str, &[f64])> = table
        .columns()
        .iter()
        .filter_map(|column| match &column.data {
            ColumnData::F64(values) => Some((column.name.as_str(), values.as_slice())),
            _ => None,
        })
        .collect();
    if n_last > 0 && n_last < columns.len() {
        columns.drain(..columns.len() - n_last);
    }
    let n_dofs = table.n_rows();
    let n_snapshots = columns.len();
    if n_snapshots == 0 || n_dofs == 0 {
        return Err(StageError::new(format!(
            "snapshots: {n_snapshots} f64 column(s) of {n_dofs} row(s): need at least one of each"
        )));
    }
    if let Some((name, values)) = columns
        .iter()
        .find(|(_, values)| values.iter().any(|v| !v.is_finite()))
    {
        let row = values.iter().position(|v| !v.is_finite()).unwrap_or(0);
        return Err(StageError::new(format!(
            "snapshots: column `{name}` row {row} is {}",
            values[row]
        )));
    }
    Ok(Mat::from_fn(n_dofs, n_snapshots, |row, col| {
        columns[col].1[row]
    }))
}

/// `X = Ψ Σ Vᵀ` with `Ψᵀ M Ψ = I` (module doc). Shapes are the columns of `shapes`.
pub struct MassSvd {
    pub singular_values: Vec<f64>,
    pub shapes: Mat<f64>,
    pub right: Mat<f64>,
}

/// The mass-weighted SVD of the snapshot columns of `x` (n × m).
pub fn mass_svd(x: &Mat<f64>, mass: &MassMatrix) -> Result<MassSvd, StageError> {
    let (n_dofs, n_snapshots) = (x.nrows(), x.ncols());
    let mut q = Mat::<f64>::zeros(n_dofs, n_snapshots);
    let mut mq = Mat::<f64>::zeros(n_dofs, n_snapshots);
    let mut r = Mat::<f64>::zeros(n_snapshots, n_snapshots);
    let mut w = vec![0.0; n_dofs];
    let mut mw = vec![0.0; n_dofs];
    for k in 0..n_snapshots {
        w.copy_from_slice(x.col_as_slice(k));
        mass.apply(&w, &mut mw);
        let norm_squared = dot(&w, &mw);
        if norm_squared < 0.0 || (norm_squared == 0.0 && w.iter().any(|&v| v != 0.0)) {
            return Err(StageError::new(format!(
                "mass matrix is not positive definite: xᵀ M x = {norm_squared:e} for snapshot {k}"
            )));
        }
        for _pass in 0..2 {
            for j in 0..k {
                let coefficient = dot(mq.col_as_slice(j), &w);
                r[(j, k)] += coefficient;
                for (w, q) in w.iter_mut().zip(q.col_as_slice(j)) {
                    *w -= coefficient * q;
                }
            }
        }
        mass.apply(&w, &mut mw);
        let norm = dot(&w, &mw).max(0.0).sqrt();
        r[(k, k)] = norm;
        if norm > 0.0 {
            for ((q, mq), (w, mw)) in q
                .col_as_slice_mut(k)
                .iter_mut()
                .zip(mq.col_as_slice_mut(k).iter_mut())
                .zip(w.iter().zip(&mw))
            {
                *q = w / norm;
                *mq = mw / norm;
            }
        }
    }
    let svd = r.svd().map_err(|err| {
        StageError::new(format!(
            "SVD of the {n_snapshots}×{n_snapshots} factor failed: {err:?}"
        ))
    })?;
    let mut shapes = q.as_ref() * svd.U();
    let mut right = svd.V().to_owned();
    let singular_values: Vec<f64> = (0..n_snapshots).map(|k| svd.S()[k]).collect();
    for k in 0..n_snapshots {
        let column = shapes.col_as_slice(k);
        let largest = column
            .iter()
            .copied()
            .max_by(|a, b| a.abs().total_cmp(&b.abs()))
            .unwrap_or(0.0);
        if largest < 0.0 {
            shapes.col_as_slice_mut(k).iter_mut().for_each(|v| *v = -*v);
            right.col_as_slice_mut(k).iter_mut().for_each(|v| *v = -*v);
        }
    }
    Ok(MassSvd {
        singular_values,
        shapes,
        right,
    })
}

/// `|φ_jᴴ M ψ_k| / ‖φ_j‖_M` for every mode j (rows) and M-unit shape k (columns).
pub fn coefficients(
    modes: &ShapeMatrices,
    shapes: &Mat<f64>,
    mass: &MassMatrix,
) -> Result<Mat<f64>, StageError> {
    let m_shapes = mass.apply_columns(shapes);
    let real_part = modes.re.transpose() * m_shapes.as_ref();
    let imag_part = modes.im.transpose() * m_shapes.as_ref();
    let m_real = mass.apply_columns(&modes.re);
    let m_imag = mass.apply_columns(&modes.im);
    let mut coefficients = Mat::<f64>::zeros(modes.modes.len(), shapes.ncols());
    for (mode_idx, mode) in modes.modes.iter().enumerate() {
        let norm_squared = dot(
            modes.re.col_as_slice(mode_idx),
            m_real.col_as_slice(mode_idx),
        ) + dot(
            modes.im.col_as_slice(mode_idx),
            m_imag.col_as_slice(mode_idx),
        );
        if norm_squared.is_nan() || norm_squared <= 0.0 {
            return Err(StageError::new(format!(
                "modes: mode {} has M-norm² {norm_squared:e}",
                mode.number
            )));
        }
        let norm = norm_squared.sqrt();
        for shape_idx in 0..shapes.ncols() {
            coefficients[(mode_idx, shape_idx)] =
                real_part[(mode_idx, shape_idx)].hypot(imag_part[(mode_idx, shape_idx)]) / norm;
        }
    }
    Ok(coefficients)
}

/// `svd_projection`: principal shapes of the last snapshots, projected on the complex modes.
pub struct SvdProjection;

crate::stage_params! {
    /// The parameters of `svd_projection`.
    pub struct ProjectionParams {
        /// snapshots used, the last ones (0: all)
        #[min = 0]
        n_last_snapshots: usize = 0,
        /// principal shapes projected and plotted
        #[min = 1]
        n_shapes: usize = 4,
    }
}

impl HasParams for SvdProjection {
    type Params = ProjectionParams;
}

impl Stage for SvdProjection {
    fn kind(&self) -> &'static str {
        "svd_projection"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Principal shapes of snapshots in the mass inner product, projected on the complex modes"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "snapshots",
                ArtifactType::Table,
                "wide: one row per DOF, one f64 column per snapshot",
            ),
            PortSpec::one(
                "complex_modes",
                ArtifactType::ComplexModes,
                "the stability stage's complex modes: those with a shape are projected on",
            ),
            PortSpec::one(
                "mass",
                ArtifactType::Table,
                "COO row, col, value (both triangles) or a `diagonal` column",
            ),
        ]
    }
    fn renamed_outputs(&self) -> &'static [(&'static str, &'static str)] {
        &[("figure", "projection_figure")]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "principal",
                ArtifactType::Table,
                "shape, singular_value, energy_fraction",
            ),
            PortSpec::one(
                "projection",
                ArtifactType::Table,
                "shape, mode, freq_hz, coefficient = |φᴴMψ| / ‖φ‖_M",
            ),
            PortSpec::one(
                "shapes",
                ArtifactType::Table,
                "wide: one row per DOF, shape_NNNN (M-unit), the first n_shapes",
            ),
            PortSpec::one(
                "projection_figure",
                ArtifactType::Figure,
                "projection coefficient against mode frequency, one panel per shape",
            ),
        ]
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let params: ProjectionParams = params.read::<Self>()?;
        let snapshot_table = inputs.table("snapshots")?;
        let x = snapshot_matrix(snapshot_table, params.n_last_snapshots)?;
        let (n_dofs, n_snapshots) = (x.nrows(), x.ncols());
        let modes: &ComplexModes = inputs.get("complex_modes")?;
        let modes = modes.shape_matrices(n_dofs, &dof_of_row(snapshot_table)?)?;
        let mass = MassMatrix::from_table(inputs.table("mass")?, n_dofs)?;

        let svd = mass_svd(&x, &mass)?;
        let n_shapes = params.n_shapes.min(n_snapshots);
        let shapes = svd.shapes.subcols(0, n_shapes).to_owned();
        let coefficients = coefficients(&modes, &shapes, &mass)?;

        let total_energy: f64 = svd.singular_values.iter().map(|s| s * s).sum();
        let energy_fraction: Vec<f64> = svd
            .singular_values
            .iter()
            .map(|s| {
                if total_energy > 0.0 {
                    s * s / total_energy
                } else {
                    0.0
                }
            })
            .collect();
        let principal = Table::new()
            .with("shape", (1..=n_snapshots as i64).collect::<Vec<i64>>())
            .with("singular_value", svd.singular_values.clone())
            .with("energy_fraction", energy_fraction.clone());

        let n_modes = modes.modes.len();
        let freqs_hz: Vec<f64> = modes.modes.iter().map(|mode| mode.freq_hz()).collect();
        let mut projection_shape = Vec::with_capacity(n_shapes * n_modes);
        let mut projection_mode = Vec::with_capacity(n_shapes * n_modes);
        let mut projection_freq = Vec::with_capacity(n_shapes * n_modes);
        let mut projection_coefficient = Vec::with_capacity(n_shapes * n_modes);
        for shape_idx in 0..n_shapes {
            for mode_idx in 0..n_modes {
                projection_shape.push(shape_idx as i64 + 1);
                projection_mode.push(modes.modes[mode_idx].number);
                projection_freq.push(freqs_hz[mode_idx]);
                projection_coefficient.push(coefficients[(mode_idx, shape_idx)]);
            }
        }
        let projection = Table::new()
            .with("shape", projection_shape)
            .with("mode", projection_mode)
            .with("freq_hz", projection_freq)
            .with("coefficient", projection_coefficient);

        let mut shapes_table = Table::new();
        for shape_idx in 0..n_shapes {
            shapes_table = shapes_table.with(
                format!("shape_{:04}", shape_idx + 1),
                shapes.col_as_slice(shape_idx).to_vec(),
            );
        }

        let plot = ProjectionPlot {
            freqs_hz: &freqs_hz,
            coefficients: &coefficients,
            energy_fraction: &energy_fraction,
        };
        let height = (180 * n_shapes as u32 + 80).clamp(300, 1400);
        let figure = plot::render(&plot, (plot::DEFAULT_SIZE.0, height))?;
        Ok(BTreeMap::from([
            ("principal".to_string(), Artifact::Table(principal)),
            ("projection".to_string(), Artifact::Table(projection)),
            ("shapes".to_string(), Artifact::Table(shapes_table)),
            ("projection_figure".to_string(), Artifact::Figure(figure)),
        ]))
    }
}

/// One panel per principal shape: a bar per mode at its frequency, as tall as the coefficient.
struct ProjectionPlot<'a> {
    freqs_hz: &'a [f64],
    coefficients: &'a Mat<f64>,
    energy_fraction: &'a [f64],
}

impl Drawing for ProjectionPlot<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let n_shapes = self.coefficients.ncols();
        let root = root
            .titled(
                "Projection of the principal shapes on the complex modes",
                (plot::FONT, 22),
            )
            .map_err(drawing_error)?;
        let panels = root.split_evenly((n_shapes, 1));
        let f_high = self.freqs_hz.iter().copied().fold(0.0, f64::max).max(1.0) * 1.05;
        let f_low = self
            .freqs_hz
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min)
            .min(0.0);
        let bar_half_width = (f_high - f_low) / 400.0;
        for (shape_idx, panel) in panels.iter().enumerate() {
            let is_last = shape_idx + 1 == n_shapes;
            let mut chart = ChartBuilder::on(panel)
                .margin(8)
                .x_label_area_size(if is_last { 45 } else { 20 })
                .y_label_area_size(60)
                .build_cartesian_2d(f_low..f_high, 0.0..1.0)
                .map_err(drawing_error)?;
            let mut mesh = chart.configure_mesh();
            mesh.disable_x_mesh()
                .y_labels(3)
                .light_line_style(WHITE)
                .y_desc(format!(
                    "shape {} ({:.1} %)",
                    shape_idx + 1,
                    100.0 * self.energy_fraction[shape_idx]
                ))
                .x_label_formatter(&|f| plot::tick_label(*f))
                .label_style((plot::FONT, 13))
                .axis_desc_style((plot::FONT, 14));
            if is_last {
                mesh.x_desc("mode frequency (Hz)");
            }
            mesh.draw().map_err(drawing_error)?;
            let color = plot::series_color(shape_idx);
            chart
                .draw_series(self.freqs_hz.iter().enumerate().map(|(mode_idx, &freq)| {
                    Rectangle::new(
                        [
                            (freq - bar_half_width, 0.0),
                            (
                                freq + bar_half_width,
                                self.coefficients[(mode_idx, shape_idx)],
                            ),
                        ],
                        color.filled(),
                    )
                }))
                .map_err(drawing_error)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;

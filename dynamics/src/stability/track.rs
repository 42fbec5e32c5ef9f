//! `stability.track`: the modes of a sweep (typically over μ) followed from one point to the
//! next by their shapes, and the coalescence figure.
//!
//! Between consecutive points a and b (in increasing order of the sweep axis) the modal
//! assurance criterion of complex shapes,
//!
//! ```text
//! MAC(φ, ψ) = |φᴴ ψ|² / ((φᴴ φ)(ψᴴ ψ))
//! ```
//!
//! pairs each mode of b with the mode of a it resembles most: pairs are taken by decreasing
//! MAC, each mode used once, and only above `min_mac`. A mode left unpaired starts a new
//! branch. Two modes that coalesce into a flutter pair share one shape, so both branches
//! continue through the coalescence; the figure shows it as two frequency lines merging while
//! their divergence rates split.

use std::sync::Arc;

use faer::{Mat, c64};

use super::figure::{Branch, coalescence_figure};
use crate::artifact::{Artifact, ArtifactType, ComplexMode, ComplexModes};
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError, Value};
use crate::table::Table;

/// A row of the tracked table: axis value, branch, mode, freq_hz, re, im, unstable, residual,
/// MAC with the previous point.
type TrackedRow = (f64, i64, i64, f64, f64, f64, bool, f64, f64);

/// One sweep point: its axis value, eigenvalue rows and shapes (columns in eigenvalue order).
struct Point {
    axis: f64,
    mode: Vec<i64>,
    freq_hz: Vec<f64>,
    re: Vec<f64>,
    im: Vec<f64>,
    unstable: Vec<bool>,
    residual: Vec<f64>,
    shapes: Mat<c64>,
}

/// The sweep's points (eigenvalues and shapes at each value of `axis`), in increasing `axis`.
fn sweep_points(
    axis: &str,
    modes: &[(crate::stage::Coords, Arc<Artifact>)],
) -> Result<Vec<Point>, StageError> {
    let axis_value = |coords: &crate::stage::Coords| -> Result<f64, StageError> {
        match coords.iter().find(|(name, _)| *name == axis) {
            Some((_, Value::Float(value))) => Ok(*value),
            Some((_, Value::Int(value))) => Ok(*value as f64),
            _ => Err(StageError::new(format!(
                "the sweep has no numeric coordinate `{axis}` (coordinates: {})",
                coords
                    .iter()
                    .map(|(name, _)| name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ))),
        }
    };
    let mut points = Vec::with_capacity(modes.len());
    for (coords, artifact) in modes {
        let Artifact::ComplexModes(modes) = artifact.as_ref() else {
            return Err(StageError::new(format!(
                "modes: a {} where complex modes are taken",
                artifact.artifact_type()
            )));
        };
        points.push(point(axis_value(coords)?, modes)?);
    }
    points.sort_by(|a, b| a.axis.total_cmp(&b.axis));

    Ok(points)
}

/// Which branch each mode of each point belongs to.
struct Branching {
    /// `branch_of[point][mode]`.
    branch_of: Vec<Vec<usize>>,
    /// The MAC that put the mode on its branch (NaN where a branch starts).
    mac_of: Vec<Vec<f64>>,
    n_branches: usize,
}

/// Follows the modes from point to point by their MAC.
fn follow_branches(points: &[Point], axis: &str, min_mac: f64) -> Result<Branching, StageError> {
    // branch of each mode at each point, and the MAC that put it there.
    let mut branch_of: Vec<Vec<usize>> = Vec::with_capacity(points.len());
    let mut mac_of: Vec<Vec<f64>> = Vec::with_capacity(points.len());
    let mut n_branches = 0;
    for (index, current) in points.iter().enumerate() {
        let n_modes = current.mode.len();
        let pairing = match index {
            0 => vec![None; n_modes],
            _ => {
                let previous = &points[index - 1];
                if previous.shapes.nrows() != current.shapes.nrows() {
                    return Err(StageError::new(format!(
                        "shapes at {axis} = {} and {} have different DOF counts",
                        previous.axis, current.axis
                    )));
                }
                pair_modes(&mac_matrix(&previous.shapes, &current.shapes), min_mac)
            }
        };
        let mut branches = Vec::with_capacity(n_modes);
        let mut macs = Vec::with_capacity(n_modes);
        for pair in pairing {
            match pair {
                Some((row, mac)) => {
                    branches.push(branch_of[index - 1][row]);
                    macs.push(mac);
                }
                None => {
                    branches.push(n_branches);
                    n_branches += 1;
                    macs.push(f64::NAN);
                }
            }
        }
        branch_of.push(branches);
        mac_of.push(macs);
    }

    Ok(Branching {
        branch_of,
        mac_of,
        n_branches,
    })
}

/// The `tracked` table, sorted by branch then `axis`, and each branch's points for the figure.
fn tracked_table(points: &[Point], axis: &str, branching: &Branching) -> (Table, Vec<Branch>) {
    let Branching {
        branch_of,
        mac_of,
        n_branches,
    } = branching;
    let mut table_rows: Vec<TrackedRow> = Vec::new();
    let mut branches: Vec<Branch> = vec![Vec::new(); *n_branches];
    for (index, point) in points.iter().enumerate() {
        for mode in 0..point.mode.len() {
            let rate = 2.0 * point.re[mode] / point.im[mode];
            let branch = branch_of[index][mode];
            table_rows.push((
                point.axis,
                branch as i64 + 1,
                point.mode[mode],
                point.freq_hz[mode],
                point.re[mode],
                point.im[mode],
                point.unstable[mode],
                point.residual[mode],
                mac_of[index][mode],
            ));
            branches[branch].push((
                point.axis,
                point.freq_hz[mode],
                100.0 * rate,
                point.unstable[mode],
            ));
        }
    }
    table_rows.sort_by(|a, b| a.1.cmp(&b.1).then(a.0.total_cmp(&b.0)));
    let column = |f: &dyn Fn(&TrackedRow) -> f64| table_rows.iter().map(f).collect::<Vec<f64>>();
    let table = Table::new()
        .with(axis, column(&|row| row.0))
        .with(
            "branch",
            table_rows.iter().map(|row| row.1).collect::<Vec<i64>>(),
        )
        .with(
            "mode",
            table_rows.iter().map(|row| row.2).collect::<Vec<i64>>(),
        )
        .with("freq_hz", column(&|row| row.3))
        .with("re", column(&|row| row.4))
        .with("im", column(&|row| row.5))
        .with("divergence_rate", column(&|row| 2.0 * row.4 / row.5))
        .with(
            "unstable",
            table_rows.iter().map(|row| row.6).collect::<Vec<bool>>(),
        )
        .with("residual", column(&|row| row.7))
        .with("mac", column(&|row| row.8));
    (table, branches)
}

fn point(axis_value: f64, modes: &ComplexModes) -> Result<Point, StageError> {
    let mut shapes: Vec<(&[f64], &[f64])> = Vec::with_capacity(modes.modes.len());
    for mode in &modes.modes {
        let shape = mode.shape.as_ref().ok_or_else(|| {
            StageError::new(format!(
                "modes: mode {} has no shape (run the stability stage with shapes: all)",
                mode.number
            ))
        })?;
        shapes.push((&shape.re, &shape.im));
    }
    let n_rows = shapes.first().map_or(0, |(re, _)| re.len());
    if let Some(mode) = shapes.iter().position(|(re, _)| re.len() != n_rows) {
        return Err(StageError::new(format!(
            "modes: mode {} has {} DOFs, mode {} has {n_rows}",
            modes.modes[mode].number,
            shapes[mode].0.len(),
            modes.modes[0].number
        )));
    }
    let column =
        |f: &dyn Fn(&ComplexMode) -> f64| -> Vec<f64> { modes.modes.iter().map(f).collect() };
    Ok(Point {
        axis: axis_value,
        mode: modes.modes.iter().map(|mode| mode.number).collect(),
        freq_hz: column(&|mode| mode.freq_hz()),
        re: column(&|mode| mode.re),
        im: column(&|mode| mode.im),
        unstable: modes.modes.iter().map(ComplexMode::is_unstable).collect(),
        residual: column(&|mode| mode.residual),
        shapes: Mat::from_fn(n_rows, shapes.len(), |row, col| {
            c64::new(shapes[col].0[row], shapes[col].1[row])
        }),
    })
}

/// MAC of every column of `A` against every column of `B`.
pub fn mac_matrix(A: &Mat<c64>, B: &Mat<c64>) -> Mat<f64> {
    let cross = A.adjoint() * B;
    let norms = |X: &Mat<c64>| -> Vec<f64> {
        (0..X.ncols())
            .map(|col| X.col(col).iter().map(|v| v.norm_sqr()).sum())
            .collect()
    };
    let (a, b) = (norms(A), norms(B));
    Mat::from_fn(A.ncols(), B.ncols(), |i, j| {
        cross[(i, j)].norm_sqr() / (a[i] * b[j]).max(f64::MIN_POSITIVE)
    })
}

/// For each column of the MAC matrix (mode of the next point), the row it continues (greedy by
/// decreasing MAC, one-to-one, MAC ≥ `min_mac`), with that MAC.
pub fn pair_modes(mac: &Mat<f64>, min_mac: f64) -> Vec<Option<(usize, f64)>> {
    let mut candidates: Vec<(usize, usize, f64)> = (0..mac.nrows())
        .flat_map(|i| (0..mac.ncols()).map(move |j| (i, j, mac[(i, j)])))
        .filter(|&(_, _, value)| value >= min_mac)
        .collect();
    candidates.sort_by(|a, b| b.2.total_cmp(&a.2));
    let mut row_used = vec![false; mac.nrows()];
    let mut pairing = vec![None; mac.ncols()];
    for (i, j, value) in candidates {
        if !row_used[i] && pairing[j].is_none() {
            row_used[i] = true;
            pairing[j] = Some((i, value));
        }
    }
    pairing
}

/// `stability.track`.
pub struct Track;

crate::stage_params! {
    /// The parameters of `stability.track`.
    pub struct TrackParams {
        /// the swept parameter to order the points by
        axis: String = "mu".into(),
        /// smallest MAC for a mode to continue a branch
        #[min = 0.0]
        min_mac: f64 = 0.5,
    }
}

impl HasParams for Track {
    type Params = TrackParams;
}

impl Stage for Track {
    fn kind(&self) -> &'static str {
        "stability.track"
    }
    fn version(&self) -> u32 {
        // 2: MAC over the model's DOFs (CHANGELOG.md, "stability.track")
        2
    }
    fn doc(&self) -> &'static str {
        "Follow the complex modes of a sweep (e.g. over mu) by MAC; one table and a coalescence figure"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::many(
            "complex_modes",
            ArtifactType::ComplexModes,
            "a stability stage's complex modes at every point, every shape kept",
        )]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "tracked",
                ArtifactType::Table,
                "axis value, branch, mode, freq_hz, re, im, divergence_rate, unstable, residual, mac",
            ),
            PortSpec::one(
                "coalescence",
                ArtifactType::Figure,
                "frequency and divergence rate of every branch against the axis",
            ),
        ]
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let TrackParams { axis, min_mac } = params.read::<Self>()?;
        let points = sweep_points(&axis, inputs.many("complex_modes")?)?;
        let branching = follow_branches(&points, &axis, min_mac)?;
        let (table, branches) = tracked_table(&points, &axis, &branching);
        let figure = coalescence_figure(&branches, &axis)?;
        Ok(Outputs::from([
            ("tracked".to_string(), Artifact::Table(table)),
            ("coalescence".to_string(), Artifact::Figure(figure)),
        ]))
    }
}

//! The candidate vectors of each `kind`, and how they join the span.
//!
//! # Rank
//!
//! The candidates are `M`-orthonormalised in order (Gram–Schmidt twice,
//! [`squeal_linalg::gram_schmidt::MSpan`]); one is kept when the `M`-norm left after its
//! projection on those before is at least `rank_tolerance` times its reference norm: for a
//! complex mode's real and imaginary parts, the norm of the whole mode off the interface (a
//! nearly real mode's imaginary part is judged against the mode, and dropped when it is
//! round-off); for the other vectors, their own norm. The `vectors` table gives every
//! candidate's norm left, kept or not.

use std::f64::consts::PI;

use faer::Mat;
use squeal_linalg::csc::symmetric_mul;
use squeal_linalg::eigensolver::{self, Band, SolveOptions};
use squeal_linalg::gram_schmidt::MSpan;

use super::static_modes::StaticModes;
use super::{BasisKind, BasisParams};
use crate::artifact::{
    ComplexMode, ComplexModes, ComplexShape, CscMatrix, Equilibrium, Model, RealModes,
};
use crate::stage::StageError;
use crate::table::Table;

/// Candidate vectors per block of `M`-norm products.
const NORM_BLOCK: usize = 64;

/// The candidate vectors of `params.kind`, and the real modes that may complete them.
pub(super) fn candidates_of(
    params: &BasisParams,
    model: &Model,
    equilibrium: &Equilibrium,
    sources: &Sources,
    interface: &[usize],
    cutoff_hz: f64,
) -> Result<(Candidates, Candidates), StageError> {
    let mut candidates = Candidates::new();
    let mut completion = Candidates::new();
    match params.kind {
        BasisKind::Fc | BasisKind::Modes | BasisKind::Adaptive => {
            let wanted = if params.kind == BasisKind::Modes {
                Wanted::Listed(list_of_modes(&params.modes)?)
            } else {
                Wanted::Lowest {
                    n_modes: params.n_modes,
                    cutoff_hz,
                }
            };
            candidates.complex_modes(sources, &wanted, model.n_dofs())?;
            if params.kind != BasisKind::Modes {
                candidates.push(&equilibrium.u, "equilibrium", -1, 0.0, None);
                if params.complete
                    && let Some(real_modes) = sources.real_modes
                {
                    completion.real_modes(real_modes, params.n_modes, cutoff_hz);
                }
            }
        }
        BasisKind::Real => {
            let real_modes = sources.real_modes.ok_or_else(|| {
                StageError::new("basis: kind real needs the `modes` input (the modes stage)")
            })?;
            let n_modes = params.n_modes;
            if n_modes > real_modes.omega.len() {
                return Err(StageError::new(format!(
                    "basis: n_modes = {n_modes}, the modes stage found {}",
                    real_modes.omega.len()
                )));
            }
            let highest = real_modes.omega.last().copied().unwrap_or(0.0) / (2.0 * PI);
            if n_modes == 0 && highest < cutoff_hz {
                return Err(StageError::new(format!(
                    "basis: the modes stage reaches {highest:.1} Hz, below the cut-off {cutoff_hz:.1} Hz: raise its band or set n_modes"
                )));
            }
            candidates.real_modes(real_modes, n_modes, cutoff_hz);
        }
        BasisKind::CraigBampton => {
            candidates.fixed_interface_modes(model, interface, params.n_modes, cutoff_hz)?
        }
    }
    // With every body kept whole there is nothing left to reduce, and no vector is right.
    if candidates.len() == 0 && interface.len() < model.n_dofs() {
        let limit = if params.n_modes > 0 {
            format!("n_modes = {}", params.n_modes)
        } else {
            format!("below {cutoff_hz:.1} Hz")
        };
        return Err(StageError::new(format!(
            "basis: no {} vector ({limit})",
            params.kind
        )));
    }
    Ok((candidates, completion))
}

/// The inputs vectors may come from.
pub(super) struct Sources<'a> {
    pub(super) complex_modes: Option<&'a ComplexModes>,
    pub(super) real_modes: Option<&'a RealModes>,
}

pub(super) enum Wanted {
    Lowest { n_modes: usize, cutoff_hz: f64 },
    Listed(Vec<i64>),
}

/// The listed mode numbers, each checked to be one (1, 2, …).
fn list_of_modes(modes: &[i64]) -> Result<Vec<i64>, StageError> {
    match modes.iter().find(|&&mode| mode < 1) {
        Some(mode) => Err(StageError::new(format!(
            "modes: `{mode}` is not a mode number (1, 2, …)"
        ))),
        None => Ok(modes.to_vec()),
    }
}

/// The cut-off frequency (Hz): given, or `cutoff_factor` × the highest unstable frequency.
pub(super) fn cutoff(params: &BasisParams, sources: &Sources) -> Result<f64, StageError> {
    if params.f_cutoff_hz > 0.0 {
        return Ok(params.f_cutoff_hz);
    }
    if params.n_modes > 0 || params.kind == BasisKind::Modes {
        return Ok(f64::INFINITY);
    }
    let modes = sources.complex_modes.ok_or_else(|| {
        StageError::new(
            "basis: the cut-off is cutoff_factor times the highest unstable frequency, which needs the `complex_modes` input; or set f_cutoff_hz or n_modes",
        )
    })?;
    let highest = modes
        .modes
        .iter()
        .filter(|mode| mode.is_unstable())
        .map(ComplexMode::freq_hz)
        .fold(0.0_f64, f64::max);
    if highest == 0.0 {
        return Err(StageError::new(
            "basis: the complex modes hold no unstable mode to set the cut-off: set f_cutoff_hz or n_modes",
        ));
    }
    Ok(params.cutoff_factor * highest)
}

/// Candidate vectors, with what a reader needs to know of each.
pub(super) struct Candidates {
    vectors: Vec<Vec<f64>>,
    source: Vec<&'static str>,
    mode: Vec<i64>,
    freq_hz: Vec<f64>,
    /// Candidates of one group (a complex mode's two parts) share their reference norm.
    group: Vec<usize>,
    /// Filled by [`Candidates::add_to`].
    remaining: Vec<f64>,
    kept: Vec<bool>,
}

impl Candidates {
    pub(super) fn new() -> Candidates {
        Candidates {
            vectors: Vec::new(),
            source: Vec::new(),
            mode: Vec::new(),
            freq_hz: Vec::new(),
            group: Vec::new(),
            remaining: Vec::new(),
            kept: Vec::new(),
        }
    }

    pub(super) fn len(&self) -> usize {
        self.vectors.len()
    }

    /// Adds `vector`; `group`: the candidate it shares a norm with.
    pub(super) fn push(
        &mut self,
        vector: &[f64],
        source: &'static str,
        mode: i64,
        freq_hz: f64,
        group: Option<usize>,
    ) {
        self.group.push(group.unwrap_or(self.vectors.len()));
        self.vectors.push(vector.to_vec());
        self.source.push(source);
        self.mode.push(mode);
        self.freq_hz.push(freq_hz);
    }

    fn complex_modes(
        &mut self,
        sources: &Sources,
        wanted: &Wanted,
        n_dofs: usize,
    ) -> Result<(), StageError> {
        let modes = sources.complex_modes.ok_or_else(|| {
            StageError::new(
                "basis: fc and modes take complex modes: connect the stability stage's `modes` to `complex_modes`",
            )
        })?;
        modes.check_dofs(n_dofs)?;
        let modes: Vec<(&ComplexMode, &ComplexShape)> = modes.with_shapes().collect();
        let mut order: Vec<usize> = (0..modes.len()).collect();
        order.sort_by(|&a, &b| modes[a].0.freq_hz().total_cmp(&modes[b].0.freq_hz()));
        let chosen: Vec<usize> = match wanted {
            Wanted::Lowest { n_modes, cutoff_hz } => {
                let below: Vec<usize> = order
                    .into_iter()
                    .filter(|&k| modes[k].0.freq_hz() <= *cutoff_hz)
                    .collect();
                if *n_modes > 0 {
                    if below.len() < *n_modes {
                        return Err(StageError::new(format!(
                            "basis: n_modes = {n_modes}, the complex modes hold {} shapes below the cut-off (does the stability stage keep `shapes: all`?)",
                            below.len()
                        )));
                    }
                    below[..*n_modes].to_vec()
                } else {
                    below
                }
            }
            Wanted::Listed(numbers) => numbers
                .iter()
                .map(|number| {
                    modes
                        .iter()
                        .position(|(mode, _)| mode.number == *number)
                        .ok_or_else(|| {
                            StageError::new(format!(
                                "basis: mode {number} has no shape among the complex modes"
                            ))
                        })
                })
                .collect::<Result<_, _>>()?,
        };
        for k in chosen {
            let (mode, shape) = modes[k];
            let first = self.len();
            for (part, vector) in [("complex_re", &shape.re), ("complex_im", &shape.im)] {
                self.push(vector, part, mode.number, mode.freq_hz(), Some(first));
            }
        }
        Ok(())
    }

    /// The first `n_modes` real modes, or (0) those below the cut-off.
    fn real_modes(&mut self, real_modes: &RealModes, n_modes: usize, cutoff_hz: f64) {
        for (k, (omega, shape)) in real_modes.omega.iter().zip(&real_modes.shapes).enumerate() {
            let freq_hz = omega / (2.0 * PI);
            let wanted = if n_modes > 0 {
                k < n_modes
            } else {
                freq_hz <= cutoff_hz
            };
            if wanted {
                self.push(shape, "real", k as i64 + 1, freq_hz, None);
            }
        }
    }

    /// The fixed-interface modes `K_oo φ = ω² M_oo φ`: the first `n_modes`, or those below
    /// the cut-off.
    fn fixed_interface_modes(
        &mut self,
        model: &Model,
        interface: &[usize],
        n_modes: usize,
        cutoff_hz: f64,
    ) -> Result<(), StageError> {
        let n = model.n_dofs();
        let mut on_interface = vec![false; n];
        for &dof in interface {
            on_interface[dof] = true;
        }
        let others: Vec<usize> = (0..n).filter(|&dof| !on_interface[dof]).collect();
        if others.is_empty() {
            // Every body kept whole: nothing is left to reduce.
            return Ok(());
        }
        let mut index = vec![usize::MAX; n];
        for (k, &dof) in others.iter().enumerate() {
            index[dof] = k;
        }
        let restrict = |A: &CscMatrix| {
            let triplets = A
                .triplets()
                .filter(|&(row, col, _)| !on_interface[row] && !on_interface[col])
                .map(|(row, col, value)| (index[row], index[col], value))
                .collect();
            CscMatrix::from_triplets(others.len(), others.len(), triplets)
        };
        let dof_of_node: Vec<[Option<u32>; 3]> = model
            .dof_of_node
            .iter()
            .map(|dofs| {
                dofs.map(|dof| {
                    dof.filter(|&dof| !on_interface[dof as usize])
                        .map(|dof| index[dof as usize] as u32)
                })
            })
            .collect();
        let lambda_hi = if n_modes > 0 {
            f64::INFINITY
        } else {
            (2.0 * PI * cutoff_hz).powi(2)
        };
        let solution = eigensolver::solve(
            &restrict(&model.K),
            &restrict(&model.M),
            &dof_of_node,
            Band {
                n_modes,
                lambda_lo: 0.0,
                lambda_hi,
            },
            SolveOptions::default(),
        )
        .map_err(|err| StageError::new(format!("basis: fixed-interface modes: {err}")))?;
        let mut full = vec![0.0; n];
        for (k, lambda) in solution.lambda.iter().enumerate() {
            for (row, &dof) in others.iter().enumerate() {
                full[dof] = solution.shapes[(row, k)];
            }
            self.push(
                &full,
                "fixed_interface",
                k as i64 + 1,
                lambda.max(0.0).sqrt() / (2.0 * PI),
                None,
            );
        }
        Ok(())
    }

    /// Extends `span` with the candidates less their static parts, `v − S v_i`, in order, at
    /// `tolerance`; returns how many it kept.
    pub(super) fn add_to(
        &mut self,
        span: &mut MSpan,
        static_modes: &StaticModes,
        M: &CscMatrix,
        tolerance: f64,
    ) -> usize {
        let n = M.n_rows;
        let interface = static_modes.interface();
        let count = self.len();
        let mut norms_squared = Vec::with_capacity(count);
        let mut blocks = Vec::new();
        for first in (0..count).step_by(NORM_BLOCK) {
            let block = &mut self.vectors[first..(first + NORM_BLOCK).min(count)];
            let X_i = Mat::from_fn(interface.len(), block.len(), |j, k| block[k][interface[j]]);
            let S_X_i = static_modes.static_displacement(X_i.as_ref());
            for (k, vector) in block.iter_mut().enumerate() {
                vector
                    .iter_mut()
                    .zip(S_X_i.col(k).iter())
                    .for_each(|(value, static_part)| *value -= static_part);
            }
            let X = Mat::from_fn(n, block.len(), |i, k| block[k][i]);
            let MX = symmetric_mul(M, X.as_ref());
            norms_squared.extend((0..block.len()).map(|k| {
                X.col(k)
                    .iter()
                    .zip(MX.col(k).iter())
                    .map(|(a, b)| a * b)
                    .sum::<f64>()
            }));
            blocks.push((first, X, MX));
        }
        let mut group_norms = vec![0.0; self.len()];
        for (k, &group) in self.group.iter().enumerate() {
            group_norms[group] += norms_squared[k];
        }
        let reference: Vec<f64> = self
            .group
            .iter()
            .map(|&group| group_norms[group].sqrt().max(f64::MIN_POSITIVE))
            .collect();
        let before = span.len();
        for (first, X, MX) in blocks {
            let reference = &reference[first..first + X.ncols()];
            let remaining = span.extend(M, X.as_ref(), MX.as_ref(), reference, tolerance);
            self.kept
                .extend(remaining.iter().map(|&ratio| ratio >= tolerance));
            self.remaining.extend(remaining);
        }
        span.len() - before
    }

    /// One row per candidate of every list, in order.
    pub(super) fn table(lists: &[Candidates]) -> Table {
        let gather_f64 = |f: &dyn Fn(&Candidates, usize) -> f64| -> Vec<f64> {
            lists
                .iter()
                .flat_map(|list| (0..list.len()).map(move |k| f(list, k)))
                .collect()
        };
        let total: usize = lists.iter().map(Candidates::len).sum();
        Table::new()
            .with("candidate", (0..total as i64).collect::<Vec<i64>>())
            .with(
                "source",
                lists
                    .iter()
                    .flat_map(|list| list.source.iter().map(|s| s.to_string()))
                    .collect::<Vec<String>>(),
            )
            .with(
                "mode",
                lists
                    .iter()
                    .flat_map(|list| list.mode.iter().copied())
                    .collect::<Vec<i64>>(),
            )
            .with("freq_hz", gather_f64(&|list, k| list.freq_hz[k]))
            .with("remaining", gather_f64(&|list, k| list.remaining[k]))
            .with(
                "kept",
                lists
                    .iter()
                    .flat_map(|list| list.kept.iter().copied())
                    .collect::<Vec<bool>>(),
            )
    }
}

//! `basis`: a reduction basis of the model and its reduced matrices, on which `transient`
//! runs the same scheme as on the full model.
//!
//! # The basis
//!
//! With `i` the interface (every free DOF of the contact pairs' nodes) and `o` the others,
//!
//! ```text
//! u = T x,   x = [u_i; q],   T = [[I, 0], [Ψ_o, Φ_o]],   Ψ_o = −K_oo⁻¹ K_oi
//! ```
//!
//! The interface DOFs stay physical, so the contact laws act on `x`'s first coordinates
//! exactly as on the full model; `[I; Ψ_o]` are the interface's static modes (unit
//! displacement of one interface DOF, the others fixed, no load off the interface). The vectors
//! `Φ` are the candidates less their static part, `v − S v_i` with `S = [I; Ψ_o]`: they vanish
//! on the interface, and every candidate `v = S v_i + (v − S v_i)` lies exactly in the span of
//! `T` (merely zeroing a mode's interface entries would leave `Ψ_o v_i` out). They are
//! `M`-orthonormal. The reduced matrices `Tᵀ M T`, `Tᵀ C T`, `Tᵀ K T` are dense and symmetric.
//! Two blocks of `Tᵀ K T` follow from the static modes' definition, `K S = [K_ii + K_io Ψ_o; 0]`,
//! and are set from it rather than summed to round-off: `Sᵀ K S = K_ii + K_io Ψ_o` (Guyan's
//! condensed stiffness: `K S`'s interface rows) and `Sᵀ K Φ = 0` (`Φ` vanishes on the
//! interface).
//!
//! With `keep_whole_up_to` = m > 0, every DOF of each body of at most m DOFs (a body: a
//! connected component of the union of `M`'s, `C`'s and `K`'s patterns, no matrix coupling it
//! to the rest) joins `i`: those bodies (a brake's pads) stay physical whole, and the vectors,
//! which vanish on `i`, reduce the other bodies (the disc) alone. The span holds the basis with
//! the interface alone, and `J` becomes block-diagonal by body (docs/science.md §5).
//!
//! The candidates, by `kind`:
//! - `fc` (the paper's FC_N): the real and imaginary parts of the first N complex modes of the
//!   stability stage, and the static equilibrium `u_e`;
//! - `real`: the first N real modes of the `modes` stage;
//! - `craig_bampton`: the first N fixed-interface modes, `K_oo φ = ω² M_oo φ`, computed here
//!   (with the static modes, the Craig–Bampton basis);
//! - `modes`: the complex modes a user lists (those near the unstable frequencies and their
//!   harmonics, say), as for `fc`;
//! - `adaptive`: `fc`, enriched by residual vectors until the transient's residual indicator
//!   meets `target` (`adaptive.rs`).
//!
//! N is `n_modes`, or every mode below the cut-off `f_cutoff_hz`, by default `cutoff_factor`
//! (1.5) times the highest unstable frequency of the stability stage.
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
//!
//! # Complex modes the stability stage did not seek
//!
//! The stability stage returns the modes whose divergence rate is within its
//! `max_divergence_rate`: heavily damped modes below the cut-off are missing (at the slow
//! sliding of the default brake, about a third of the band). They are damped by friction at
//! the contact (the friction-direction damping `μ r_n / |v_g|` acts on the pairs' tangential
//! motion), so their deformation is driven from the interface, and the interface's static
//! modes, which every basis here holds, represent it: on the test brake, the 20 of 38 modes
//! below 8 kHz that a 0.5 % band leaves out lie within 0.4 % (in `M`-norm) of the span of the
//! basis built without them (`the_modes_the_stability_band_leaves_out_lie_in_the_span_of_the_basis`).
//! Widening the band instead would cost a shift-invert Arnoldi over the damped region, for
//! modes the transient only needs as a subspace. As a safeguard for other models, with the
//! `modes` input connected and `complete: true`, `fc` also adds every real mode below the
//! cut-off of which at least [`COMPLETION_FRACTION`] of the `M`-norm lies outside the span
//! so far: an undamped mode that the vectors found do not represent. (`modes` lists are taken
//! as given.)

mod adaptive;
pub mod pareto;
#[cfg(test)]
mod tests;

use std::f64::consts::PI;

use faer::{Mat, MatRef};
use squeal_linalg::csc::{components, symmetric_mul, symmetric_mul_rows};
use squeal_linalg::eigensolver::{self, Band, SolveOptions};
use squeal_linalg::gram_schmidt::MSpan;
use squeal_linalg::tall::transpose_times;

use crate::artifact::basis::{StaticBlock, StaticModes, interface_dofs};
use crate::artifact::{Artifact, ArtifactType, Basis, CscMatrix, Equilibrium, Model, RealModes};
use crate::complex_modes::ComplexModes;
use crate::stage::{
    HasParams, Inputs, Outputs, Params, PortSpec, Resources, RunContext, Stage, StageError,
};
use crate::table::{ColumnData, Table};

/// A real mode completes `fc` when at least this fraction of its `M`-norm lies outside the
/// span of the complex modes (and vectors) before it.
pub const COMPLETION_FRACTION: f64 = 0.5;

/// The index of `K` in [`Reduction::matrices`] (`M`, `C`, `K`).
const STIFFNESS: usize = 2;

/// Candidate vectors per block of `M`-norm products.
const NORM_BLOCK: usize = 64;

pub struct ReductionBasis;

crate::choice! {
    /// The family of vectors a basis is built from.
    pub enum BasisKind {
        Fc = "fc",
        Real = "real",
        CraigBampton = "craig_bampton",
        Modes = "modes",
        Adaptive = "adaptive",
    }
}

crate::stage_params! {
    /// The parameters of `basis`.
    pub struct BasisParams {
        /// vectors off the interface: complex modes and the equilibrium, real modes,
        /// fixed-interface modes, the complex modes listed in `modes`, or fc enriched until the
        /// residual indicator meets `target`
        kind: BasisKind = BasisKind::Fc,
        /// modes taken (0: every mode below the cut-off)
        #[min = 0]
        n_modes: usize = 0,
        /// cut-off frequency (0: cutoff_factor times the highest unstable frequency)
        #[unit = "Hz"]
        #[min = 0.0]
        f_cutoff_hz: f64 = 0.0,
        /// cut-off over the highest unstable frequency, when f_cutoff_hz is 0
        #[min = 0.0]
        cutoff_factor: f64 = 1.5,
        /// kind modes: complex mode numbers of the stability tables
        modes: Vec<i64> = Vec::new(),
        /// a vector is kept when this fraction of its reference M-norm lies outside the span of
        /// those before
        #[min = 0.0]
        rank_tolerance: f64 = 1e-3,
        /// fc: add the real modes below the cut-off that the complex modes found do not span (needs
        /// the modes input)
        complete: bool = true,
        /// adaptive: the residual indicator to reach (see the transient's residual_indicator)
        #[min = 0.0]
        target: f64 = 1e-3,
        /// adaptive: most enrichment rounds
        #[min = 1]
        max_rounds: usize = 8,
        /// adaptive: length of the reduced probe run of each round
        #[unit = "s"]
        #[min = 0.0]
        probe_duration: f64 = 2e-3,
        /// adaptive: the probe run's time step
        #[unit = "s"]
        #[min = 0.0]
        probe_tau: f64 = 1e-6,
        /// adaptive: the probe starts from the most unstable mode at this amplitude (small: the
        /// linear growth; a probe into the contact nonlinearity may not converge, docs/science.md
        /// section 5)
        #[unit = "m"]
        #[min = 0.0]
        probe_amplitude: f64 = 1e-9,
        /// adaptive: steps of the probe checked against the full step equation; each gives a
        /// residual vector and a correction
        #[min = 1]
        probe_samples: usize = 20,
        /// bodies (DOF sets no matrix couples: the disc, each pad) of at most this many DOFs stay
        /// physical whole, with the interface, and the vectors reduce the others (0: the interface
        /// alone, the paper's bases)
        #[min = 0]
        keep_whole_up_to: usize = 0,
    }
}

impl HasParams for ReductionBasis {
    type Params = BasisParams;
}

impl Stage for ReductionBasis {
    fn kind(&self) -> &'static str {
        "basis"
    }
    fn version(&self) -> u32 {
        // 10: the basis holds its static modes `Ψ_o` (CHANGELOG.md, "basis")
        10
    }
    fn doc(&self) -> &'static str {
        "Reduction basis (complex modes FC_N, real modes, Craig-Bampton, a list of complex modes, or adaptive) with the interface's static modes, and the reduced M, C, K"
    }
    fn resources(&self) -> Resources {
        Resources::job(2, 8192)
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "model",
                ArtifactType::Model,
                "M, C, K and the contact pairs",
            ),
            PortSpec::one(
                "equilibrium",
                ArtifactType::Equilibrium,
                "the sliding equilibrium (fc takes u_e)",
            ),
            PortSpec::one(
                "eigenvalues",
                ArtifactType::Table,
                "fc, modes: the stability stage's eigenvalues",
            )
            .optional(),
            PortSpec::one(
                "shapes",
                ArtifactType::Table,
                "fc, modes: the stability stage's mode shapes",
            )
            .optional(),
            PortSpec::one(
                "modes",
                ArtifactType::RealModes,
                "real: the modes stage's real modes; fc: the completion",
            )
            .optional(),
        ]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "basis",
                ArtifactType::Basis,
                "the basis and the reduced M, C, K (the transient's basis input)",
            ),
            PortSpec::one(
                "vectors",
                ArtifactType::Table,
                "every candidate vector: source, mode, freq_hz, the fraction of its norm left after projection, kept",
            ),
            PortSpec::one(
                "summary",
                ArtifactType::Table,
                "sizes, rank, cut-off, M-orthonormality and symmetry errors",
            ),
            PortSpec::one(
                "rounds",
                ArtifactType::Table,
                "adaptive: per round, round, n_vectors, n_reduced, indicator (no rows for the other kinds)",
            ),
        ]
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        self.run_with(params, inputs, &RunContext::detached())
    }
    fn run_with(
        &self,
        params: &Params,
        inputs: &Inputs,
        context: &RunContext,
    ) -> Result<Outputs, StageError> {
        let params: BasisParams = params.read::<Self>()?;
        if !(params.rank_tolerance > 0.0 && params.rank_tolerance < 1.0) {
            return Err(StageError::new(format!(
                "basis: rank_tolerance = {}: a fraction of a vector's norm, between 0 and 1 (exclusive)",
                params.rank_tolerance
            )));
        }
        let model: &Model = inputs.get("model")?;
        let equilibrium: &Equilibrium = inputs.get("equilibrium")?;
        model.check_dof_map()?;
        equilibrium
            .check_belongs_to(model)
            .map_err(|err| StageError::new(format!("basis: {}", err.message)))?;
        let contact_dofs = interface_dofs(model);
        if contact_dofs.is_empty() {
            return Err(StageError::new(
                "basis: the model has no contact pair, so no interface to keep",
            ));
        }
        let bodies = components(&[&model.M, &model.C, &model.K]);
        let interface = with_whole_bodies(&bodies, &contact_dofs, params.keep_whole_up_to);
        // The phases' shares of an fc build on the default brake; an adaptive basis reports
        // its rounds instead. `squeal run -v` logs them, timed.
        let phase = |fraction: f64, message: String| {
            tracing::info!("basis: {message}");
            let fraction = if params.kind == BasisKind::Adaptive {
                0.0
            } else {
                fraction
            };
            context.progress.report(fraction, &message);
        };
        phase(
            0.0,
            format!(
                "static modes of the {} interface DOFs and {} of whole bodies",
                contact_dofs.len(),
                interface.len() - contact_dofs.len()
            ),
        );
        let static_modes = StaticModes::new(model, &interface)?;
        let sources = Sources {
            eigenvalues: inputs.get_optional("eigenvalues")?,
            shapes: inputs.get_optional("shapes")?,
            real_modes: inputs.get_optional("modes")?,
        };
        let cutoff_hz = cutoff(&params, &sources)?;
        let (mut candidates, mut completion) =
            candidates_of(&params, model, equilibrium, &sources, &interface, cutoff_hz)?;
        phase(
            0.03,
            format!(
                "M-orthonormalising {} candidates",
                candidates.len() + completion.len()
            ),
        );
        let mut span = MSpan::with_capacity(model.n_dofs(), candidates.len() + completion.len());
        candidates.add_to(&mut span, &static_modes, &model.M, params.rank_tolerance);
        let kept_completion =
            completion.add_to(&mut span, &static_modes, &model.M, COMPLETION_FRACTION);
        phase(
            0.5,
            format!("M, C, K on the {} static modes", interface.len()),
        );
        let mut reduction = Reduction::new(model, &static_modes, bodies);
        phase(0.7, format!("M, C, K on the {} vectors", span.len()));
        reduction.extend(model, span.vectors());
        let mut lists = vec![candidates, completion];
        let rounds = if params.kind == BasisKind::Adaptive {
            let probe = adaptive::Probe {
                model,
                equilibrium,
                sources: &sources,
                static_modes: &static_modes,
                duration: params.probe_duration,
                tau: params.probe_tau,
                amplitude: params.probe_amplitude,
                samples: params.probe_samples,
            };
            let enrichment = adaptive::Enrichment {
                target: params.target,
                max_rounds: params.max_rounds,
                rank_tolerance: params.rank_tolerance,
            };
            adaptive::enrich(
                &probe,
                &enrichment,
                (&mut span, &mut reduction, &mut lists),
                context,
            )?
        } else {
            Vec::new()
        };
        let orthonormality = orthonormality_error(&reduction);
        let basis = reduction.basis(params.kind.name());
        let n_candidates: usize = lists.iter().map(Candidates::len).sum();
        let mut summary: Vec<(&str, f64)> = vec![
            ("n_dofs", model.n_dofs() as f64),
            ("n_interface", contact_dofs.len() as f64),
            ("n_whole", (interface.len() - contact_dofs.len()) as f64),
            ("n_candidates", n_candidates as f64),
            ("n_vectors", basis.vectors.len() as f64),
            ("n_completion", kept_completion as f64),
            ("n_reduced", basis.n_reduced() as f64),
            ("f_cutoff_hz", cutoff_hz),
            ("orthonormality_error", orthonormality),
            ("mass_asymmetry", reduction.asymmetry[0]),
            ("damping_asymmetry", reduction.asymmetry[1]),
            ("stiffness_asymmetry", reduction.asymmetry[2]),
        ];
        if let Some(last) = rounds.last() {
            summary.push(("rounds", rounds.len() as f64));
            summary.push(("indicator", last.indicator));
        }
        let vectors_table = Candidates::table(&lists);
        Ok(Outputs::from([
            ("basis".to_string(), Artifact::Basis(Box::new(basis))),
            ("vectors".to_string(), Artifact::Table(vectors_table)),
            (
                "summary".to_string(),
                Artifact::Table(Table::quantities(&summary)),
            ),
            (
                "rounds".to_string(),
                Artifact::Table(adaptive::table(&rounds)),
            ),
        ]))
    }
}

/// The DOFs kept physical: the contact interface's, and every DOF of the bodies (sets of DOFs
/// that no matrix couples) of at most `up_to` DOFs; ascending.
fn with_whole_bodies(bodies: &[Vec<usize>], contact_dofs: &[usize], up_to: usize) -> Vec<usize> {
    let mut physical = contact_dofs.to_vec();
    if up_to > 0 {
        bodies
            .iter()
            .filter(|body| body.len() <= up_to)
            .for_each(|body| physical.extend(body));
        physical.sort_unstable();
        physical.dedup();
    }
    physical
}

/// The candidate vectors of `params.kind`, and the real modes that may complete them.
fn candidates_of(
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
struct Sources<'a> {
    eigenvalues: Option<&'a Table>,
    shapes: Option<&'a Table>,
    real_modes: Option<&'a RealModes>,
}

enum Wanted {
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
fn cutoff(params: &BasisParams, sources: &Sources) -> Result<f64, StageError> {
    if params.f_cutoff_hz > 0.0 {
        return Ok(params.f_cutoff_hz);
    }
    if params.n_modes > 0 || params.kind == BasisKind::Modes {
        return Ok(f64::INFINITY);
    }
    let eigenvalues = sources.eigenvalues.ok_or_else(|| {
        StageError::new(
            "basis: the cut-off is cutoff_factor times the highest unstable frequency, which needs the `eigenvalues` input; or set f_cutoff_hz or n_modes",
        )
    })?;
    let (Some(ColumnData::F64(freqs_hz)), Some(ColumnData::Bool(unstable))) = (
        eigenvalues.column("freq_hz"),
        eigenvalues.column("unstable"),
    ) else {
        return Err(StageError::new(
            "basis: the eigenvalues table has no f64 `freq_hz` and bool `unstable` columns",
        ));
    };
    let highest = freqs_hz
        .iter()
        .zip(unstable)
        .filter(|(_, unstable)| **unstable)
        .map(|(freq_hz, _)| *freq_hz)
        .fold(0.0_f64, f64::max);
    if highest == 0.0 {
        return Err(StageError::new(
            "basis: the stability tables hold no unstable mode to set the cut-off: set f_cutoff_hz or n_modes",
        ));
    }
    Ok(params.cutoff_factor * highest)
}

/// Candidate vectors, with what a reader needs to know of each.
struct Candidates {
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
    fn new() -> Candidates {
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

    fn len(&self) -> usize {
        self.vectors.len()
    }

    /// Adds `vector`; `group`: the candidate it shares a norm with.
    fn push(
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
        let (Some(eigenvalues), Some(shapes)) = (sources.eigenvalues, sources.shapes) else {
            return Err(StageError::new(
                "basis: fc and modes take complex modes: connect the stability stage's `eigenvalues` and `shapes`",
            ));
        };
        let modes = ComplexModes::from_tables(shapes, eigenvalues)?;
        let dofs: &[i64] = match shapes.column("dof") {
            Some(ColumnData::I64(values)) => values,
            _ => {
                return Err(StageError::new(
                    "basis: the shapes table has no i64 column `dof`",
                ));
            }
        };
        let mut order: Vec<usize> = (0..modes.numbers.len()).collect();
        order.sort_by(|&a, &b| modes.freqs_hz[a].total_cmp(&modes.freqs_hz[b]));
        let chosen: Vec<usize> = match wanted {
            Wanted::Lowest { n_modes, cutoff_hz } => {
                let below: Vec<usize> = order
                    .into_iter()
                    .filter(|&k| modes.freqs_hz[k] <= *cutoff_hz)
                    .collect();
                if *n_modes > 0 {
                    if below.len() < *n_modes {
                        return Err(StageError::new(format!(
                            "basis: n_modes = {n_modes}, the stability tables hold {} mode shapes (does the stability stage keep `shapes: all`?)",
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
                        .numbers
                        .iter()
                        .position(|m| m == number)
                        .ok_or_else(|| {
                            StageError::new(format!(
                                "basis: mode {number} has no shape in the stability tables"
                            ))
                        })
                })
                .collect::<Result<_, _>>()?,
        };
        let mut full = vec![0.0; n_dofs];
        for k in chosen {
            let first = self.len();
            for (part, columns) in [("complex_re", &modes.real), ("complex_im", &modes.imag)] {
                full.iter_mut().for_each(|value| *value = 0.0);
                for (row, &dof) in dofs.iter().enumerate() {
                    if dof >= 0 && (dof as usize) < n_dofs {
                        full[dof as usize] = columns[(row, k)];
                    }
                }
                self.push(
                    &full,
                    part,
                    modes.numbers[k],
                    modes.freqs_hz[k],
                    Some(first),
                );
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
    fn add_to(
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
    fn table(lists: &[Candidates]) -> Table {
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

/// `max |Vᵀ M V − I|` over the vectors `V`, from the reduced mass (fresh products, not the
/// span's carried ones).
fn orthonormality_error(reduction: &Reduction) -> f64 {
    let n_i = reduction.interface.len();
    let gram = reduction.matrices[0].as_ref().submatrix(
        n_i,
        n_i,
        reduction.V.ncols(),
        reduction.V.ncols(),
    );
    let mut worst = 0.0_f64;
    for j in 0..gram.ncols() {
        for i in 0..gram.nrows() {
            let expected = if i == j { 1.0 } else { 0.0 };
            worst = worst.max((gram[(i, j)] - expected).abs());
        }
    }
    worst
}

/// `max |B − Bᵀ| / max |B|` of a square `B` (zero for a zero `B`).
fn asymmetry_of(B: MatRef<'_, f64>) -> f64 {
    let (mut largest, mut asymmetry) = (0.0_f64, 0.0_f64);
    for j in 0..B.ncols() {
        for i in 0..B.nrows() {
            largest = largest.max(B[(i, j)].abs());
            asymmetry = asymmetry.max((B[(i, j)] - B[(j, i)]).abs());
        }
    }
    if largest > 0.0 {
        asymmetry / largest
    } else {
        0.0
    }
}

/// `X[rows, :]`.
fn rows_of(X: MatRef<'_, f64>, rows: &[usize]) -> Mat<f64> {
    Mat::from_fn(rows.len(), X.ncols(), |r, k| X[(rows[r], k)])
}

/// The reduced matrices `Tᵀ A T` of `A = M, C, K`, `T = [S, V]`, grown a block of vectors at a
/// time (an adaptive basis appends vectors to a span whose earlier vectors stay as they are).
///
/// No matrix couples two bodies (the connected components of the matrices' patterns; the
/// contact pairs are not in them), so neither do the static modes: the static mode of an
/// interface DOF lies on its body, and `Sᵀ A S` is block-diagonal by body. Each body's block,
/// and its rows of `Sᵀ A V`, are products over its DOFs alone: the disc's interface DOFs do
/// not sweep the pads' rows, nor the pads' the disc's.
struct Reduction {
    /// The interface DOFs.
    interface: Vec<usize>,
    bodies: Vec<BodyModes>,
    /// The vectors `V`, after the static modes.
    V: Mat<f64>,
    /// `Tᵀ M T`, `Tᵀ C T`, `Tᵀ K T`, symmetrised.
    matrices: [Mat<f64>; 3],
    /// The largest `max |B − Bᵀ| / max |B|` over the diagonal blocks `B` computed, per matrix.
    asymmetry: [f64; 3],
    /// [`Model::fingerprint`] of the model the matrices are projected from.
    model: [u8; 32],
}

/// The static modes of the interface DOFs on one body.
struct BodyModes {
    /// The body's DOFs, ascending.
    dofs: Vec<usize>,
    /// The positions on the interface of the body's interface DOFs.
    columns: Vec<usize>,
    /// `S[dofs, columns]`: the static modes on their body (zero elsewhere).
    S: Mat<f64>,
}

impl Reduction {
    /// `T` = the static modes of the interface; `bodies`: the model's, `csc::components` of
    /// its matrices.
    fn new(model: &Model, static_modes: &StaticModes, bodies: Vec<Vec<usize>>) -> Reduction {
        let interface = static_modes.interface();
        let n_i = interface.len();
        let matrices = [&model.M, &model.C, &model.K];
        let mut position = vec![usize::MAX; model.n_dofs()];
        for (k, &dof) in interface.iter().enumerate() {
            position[dof] = k;
        }
        let bodies: Vec<BodyModes> = bodies
            .into_iter()
            .filter_map(|dofs| {
                let columns: Vec<usize> = dofs
                    .iter()
                    .map(|&dof| position[dof])
                    .filter(|&k| k != usize::MAX)
                    .collect();
                if columns.is_empty() {
                    return None;
                }
                let mut X_i = Mat::<f64>::zeros(n_i, columns.len());
                for (j, &k) in columns.iter().enumerate() {
                    X_i[(k, j)] = 1.0;
                }
                let S = rows_of(
                    static_modes.static_displacement(X_i.as_ref()).as_ref(),
                    &dofs,
                );
                Some(BodyModes { dofs, columns, S })
            })
            .collect();
        let mut reduction = Reduction {
            interface: interface.to_vec(),
            bodies,
            V: Mat::zeros(model.n_dofs(), 0),
            matrices: std::array::from_fn(|_| Mat::zeros(n_i, n_i)),
            asymmetry: [0.0; 3],
            model: model.fingerprint(),
        };
        for (which, A) in matrices.into_iter().enumerate() {
            for body in &reduction.bodies {
                let A_body = A.principal_submatrix(&body.dofs);
                let B = if which == STIFFNESS {
                    // `K S` vanishes off the interface, where `S` is the identity.
                    let on_interface: Vec<usize> = (0..body.dofs.len())
                        .filter(|&r| position[body.dofs[r]] != usize::MAX)
                        .collect();
                    symmetric_mul_rows(&A_body, &on_interface, body.S.as_ref())
                } else {
                    transpose_times(
                        body.S.as_ref(),
                        symmetric_mul(&A_body, body.S.as_ref()).as_ref(),
                    )
                };
                let R = &mut reduction.matrices[which];
                for (j, &column) in body.columns.iter().enumerate() {
                    for (i, &row) in body.columns.iter().enumerate() {
                        R[(row, column)] = 0.5 * (B[(i, j)] + B[(j, i)]);
                    }
                }
                reduction.asymmetry[which] =
                    reduction.asymmetry[which].max(asymmetry_of(B.as_ref()));
            }
        }
        reduction
    }

    /// `V ← [V, W]`: the new rows and columns of each reduced matrix, `[S, V, W]ᵀ A W`.
    fn extend(&mut self, model: &Model, W: MatRef<'_, f64>) {
        let (n_i, n_v, p) = (self.interface.len(), self.V.ncols(), W.ncols());
        let mut V = Mat::<f64>::zeros(self.V.nrows(), n_v + p);
        V.as_mut().subcols_mut(0, n_v).copy_from(&self.V);
        V.as_mut().subcols_mut(n_v, p).copy_from(W);
        let n_old = n_i + n_v;
        let vanishes_on_interface = self
            .interface
            .iter()
            .all(|&dof| W.row(dof).iter().all(|&w| w == 0.0));
        for (which, A) in [&model.M, &model.C, &model.K].into_iter().enumerate() {
            let AW = symmetric_mul(A, W);
            let mut R = Mat::<f64>::zeros(n_old + p, n_old + p);
            R.as_mut()
                .submatrix_mut(0, 0, n_old, n_old)
                .copy_from(&self.matrices[which]);
            // `Sᵀ K W = (K S)ᵀ W = 0`: `K S` vanishes off the interface, and `W` on it, as
            // every vector less its static part does.
            let bodies = if which == STIFFNESS && vanishes_on_interface {
                &[][..]
            } else {
                &self.bodies[..]
            };
            for body in bodies {
                let AW_body = rows_of(AW.as_ref(), &body.dofs);
                let B = transpose_times(body.S.as_ref(), AW_body.as_ref());
                for j in 0..p {
                    for (i, &row) in body.columns.iter().enumerate() {
                        R[(row, n_old + j)] = B[(i, j)];
                        R[(n_old + j, row)] = B[(i, j)];
                    }
                }
            }
            let B = transpose_times(V.as_ref(), AW.as_ref());
            for j in 0..p {
                for i in 0..n_v {
                    R[(n_i + i, n_old + j)] = B[(i, j)];
                    R[(n_old + j, n_i + i)] = B[(i, j)];
                }
                for i in 0..p {
                    R[(n_old + i, n_old + j)] = 0.5 * (B[(n_v + i, j)] + B[(n_v + j, i)]);
                }
            }
            self.asymmetry[which] =
                self.asymmetry[which].max(asymmetry_of(B.as_ref().subrows(n_v, p)));
            self.matrices[which] = R;
        }
        self.V = V;
    }

    /// The basis of the vectors `V`, with these matrices.
    fn basis(&self, kind: &str) -> Basis {
        // Both triangles, the exact zeros between separate bodies left out.
        let compressed = |A: &Mat<f64>| {
            let entries = (0..A.ncols())
                .flat_map(|j| (0..A.nrows()).map(move |i| (i, j, A[(i, j)])))
                .filter(|&(_, _, value)| value != 0.0)
                .collect();
            CscMatrix::from_triplets(A.nrows(), A.ncols(), entries)
        };
        let column_major = |A: &Mat<f64>| -> Vec<f64> {
            (0..A.ncols())
                .flat_map(|j| A.col(j).iter().copied().collect::<Vec<_>>())
                .collect()
        };
        Basis {
            kind: kind.to_string(),
            model: self.model,
            interface: self.interface.iter().map(|&dof| dof as u32).collect(),
            vectors: (0..self.V.ncols())
                .map(|k| self.V.col(k).iter().copied().collect())
                .collect(),
            mass: compressed(&self.matrices[0]),
            damping: compressed(&self.matrices[1]),
            stiffness: compressed(&self.matrices[2]),
            n_dofs: self.V.nrows(),
            static_modes: self
                .bodies
                .iter()
                .map(|body| {
                    let (rows, dofs): (Vec<usize>, Vec<u32>) = body
                        .dofs
                        .iter()
                        .enumerate()
                        .filter(|&(_, &dof)| self.interface.binary_search(&dof).is_err())
                        .map(|(r, &dof)| (r, dof as u32))
                        .unzip();
                    StaticBlock {
                        values: column_major(&rows_of(body.S.as_ref(), &rows)),
                        rows: dofs,
                        columns: body.columns.iter().map(|&k| k as u32).collect(),
                    }
                })
                .filter(|block| !block.rows.is_empty())
                .collect(),
        }
    }
}

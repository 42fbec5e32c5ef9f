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
mod candidates;
pub mod pareto;
mod reduction;
mod static_modes;
#[cfg(test)]
mod tests;

use squeal_linalg::csc::components;
use squeal_linalg::gram_schmidt::MSpan;

use crate::artifact::{Artifact, ArtifactType, Equilibrium, Model};
use crate::stage::{
    HasParams, Inputs, Outputs, Params, PortSpec, Resources, RunContext, Stage, StageError,
};
use crate::table::Table;
use candidates::{Candidates, Sources, candidates_of, cutoff};
use reduction::{Reduction, orthonormality_error};
pub use static_modes::{StaticModes, interface_dofs};

/// A real mode completes `fc` when at least this fraction of its `M`-norm lies outside the
/// span of the complex modes (and vectors) before it.
pub const COMPLETION_FRACTION: f64 = 0.5;

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
        // 11: the adaptive basis's probe is transient version 19 (CHANGELOG.md, "basis")
        11
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
                "complex_modes",
                ArtifactType::ComplexModes,
                "fc, modes, adaptive, the cut-off: the stability stage's complex modes",
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
            complex_modes: inputs.get_optional("complex_modes")?,
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

//! `kind: adaptive`: an `fc` basis enriched until the transient's residual indicator meets a
//! target.
//!
//! Each round runs a short reduced probe (from the most unstable mode at `probe_amplitude`:
//! by default the linear growth, where the enrichment converges; docs/science.md §5)
//! and evaluates, at `probe_samples` steps, the residual `R_k` of the full step equation on the
//! lifted reduced solution and the indicator `η` ([`crate::transient::reduced`]). While `η` is
//! above the target, two vectors per sampled step join the basis:
//!
//! ```text
//! z_k = [0; K_oo⁻¹ R_k,o]     (the static response to the residual, interface held)
//! δv_k = J⁻¹ R_k              (the velocity correction the full step would make)
//! ```
//!
//! less their static parts and `M`-orthonormalised against the basis at the rank tolerance.
//! `z_k` is the residual vector of component mode synthesis, which carries the low-frequency,
//! quasi-static part of what the basis missed; `δv_k` is what the indicator measures, and
//! carries the inertial part (on the test brake from FC_2, the pair takes the indicator from
//! 0.37 to 0.005 in three rounds, where the residual vectors alone need four and the
//! corrections alone stay above 0.02 after eight). `Tᵀ R_k = 0` makes
//! both new to the span unless `R_k` vanishes, and the reduced matrices only gain rows and
//! columns ([`super::Reduction::extend`]). No full run is needed: one factorisation of the full
//! `J` and one solve per sampled step.

use super::StaticModes;
use super::{Candidates, Reduction, Sources};
use crate::artifact::{Equilibrium, Model};
use crate::stage::{RunContext, StageError};
use crate::table::Table;
use crate::transient::contact::Solver;
use crate::transient::reduced::FullStep;
use crate::transient::scheme::{Settings, SolveBy};
use crate::transient::{self, MAX_STEPS, most_unstable_start, run_reduced, spread_steps};
use squeal_linalg::gram_schmidt::MSpan;

/// The probe run of each round.
pub(super) struct Probe<'a> {
    pub model: &'a Model,
    pub equilibrium: &'a Equilibrium,
    pub sources: &'a Sources<'a>,
    pub static_modes: &'a StaticModes,
    pub duration: f64,
    pub tau: f64,
    pub amplitude: f64,
    pub samples: usize,
}

/// When to stop, and which vectors to keep.
pub(super) struct Enrichment {
    pub target: f64,
    pub max_rounds: usize,
    pub rank_tolerance: f64,
}

/// A round's basis and its indicator.
pub(super) struct Round {
    pub n_vectors: usize,
    pub n_reduced: usize,
    pub indicator: f64,
}

/// Enriches `span` (and `reduction`, which holds its vectors after the interface's) until the
/// indicator meets the target; each round's vectors join `lists`.
pub(super) fn enrich(
    probe: &Probe,
    enrichment: &Enrichment,
    (span, reduction, lists): (&mut MSpan, &mut Reduction, &mut Vec<Candidates>),
    context: &RunContext,
) -> Result<Vec<Round>, StageError> {
    let model = probe.model;
    let Some(modes) = probe.sources.complex_modes else {
        return Err(StageError::new(
            "basis: adaptive starts its probe from the most unstable mode: connect the stability stage's `modes` to `complex_modes`",
        ));
    };
    let steps = probe.duration / probe.tau;
    if !(probe.tau > 0.0) || !(steps >= 0.5) || steps > MAX_STEPS as f64 {
        return Err(StageError::new(format!(
            "basis: adaptive: probe_duration = {} s and probe_tau = {} s give {steps:.3e} steps; a probe takes between 1 and {MAX_STEPS}",
            probe.duration, probe.tau
        )));
    }
    let n_steps = steps.round() as usize;
    let (structure, contact_state) = transient::structure_of(model, probe.equilibrium)?;
    let theta = 0.5;
    let settings = Settings {
        theta,
        tau: probe.tau,
        n_steps,
        solver: Solver::ActiveSet,
        tolerance: 1e-10,
        max_iterations: 2000,
        output_every: n_steps,
        record_pairs: Vec::new(),
        record_dofs: Vec::new(),
        record_contacts: false,
        snapshot_steps: Vec::new(),
        sample_steps: spread_steps(n_steps, probe.samples),
        solve_by: SolveBy::Choice,
    };
    let full_step = FullStep::new(&structure, theta, probe.tau)?;
    let start = most_unstable_start(modes, model.n_dofs(), probe.amplitude)?;
    let mut rounds = Vec::new();
    for round in 1..=enrichment.max_rounds {
        let basis = reduction.basis("adaptive");
        let run = run_reduced(
            model,
            (&structure, &contact_state),
            &basis,
            &settings,
            start.clone(),
            &RunContext::detached(),
        )
        .map_err(|err| {
            StageError::new(format!(
                "basis: adaptive: the probe of round {round} ({} vectors): {err}",
                basis.vectors.len()
            ))
        })?;
        let indicator = full_step.indicator(&basis, &structure, &contact_state, &run.samples);
        rounds.push(Round {
            n_vectors: basis.vectors.len(),
            n_reduced: basis.n_reduced(),
            indicator: indicator.value,
        });
        context.progress.report(
            round as f64 / enrichment.max_rounds as f64,
            &format!(
                "round {round}: {} vectors, indicator {:.3e} (target {:.3e})",
                basis.vectors.len(),
                indicator.value,
                enrichment.target
            ),
        );
        if indicator.value <= enrichment.target {
            return Ok(rounds);
        }
        if round == enrichment.max_rounds {
            break;
        }
        let responses = probe
            .static_modes
            .fixed_interface_response(indicator.residuals.as_ref());
        let mut residual_vectors = Candidates::new();
        for (k, &(t, _)) in indicator.per_step.iter().enumerate() {
            let response: Vec<f64> = responses.col(k).iter().copied().collect();
            residual_vectors.push(&response, "residual", round as i64, t, None);
        }
        for (k, &(t, _)) in indicator.per_step.iter().enumerate() {
            let correction: Vec<f64> = indicator.corrections.col(k).iter().copied().collect();
            residual_vectors.push(&correction, "correction", round as i64, t, None);
        }
        let before = span.len();
        let kept = residual_vectors.add_to(
            span,
            probe.static_modes,
            &model.M,
            enrichment.rank_tolerance,
        );
        lists.push(residual_vectors);
        if kept == 0 {
            return Err(StageError::new(format!(
                "basis: adaptive: round {round}'s residual vectors lie within the span already (indicator {:.3e}, target {:.3e}, rank_tolerance {:e}): lower rank_tolerance or raise the target",
                indicator.value, enrichment.target, enrichment.rank_tolerance
            )));
        }
        reduction.extend(model, span.vectors().subcols(before, kept));
    }
    let last = rounds.last().expect("max_rounds is at least 1");
    Err(StageError::new(format!(
        "basis: adaptive: the residual indicator is {:.3e} after {} rounds ({} vectors), above the target {:.3e} (per round: {}): raise max_rounds or the target",
        last.indicator,
        rounds.len(),
        last.n_vectors,
        enrichment.target,
        rounds
            .iter()
            .map(|round| format!("{:.3e}", round.indicator))
            .collect::<Vec<_>>()
            .join(", ")
    )))
}

/// One row per round.
pub(super) fn table(rounds: &[Round]) -> Table {
    Table::new()
        .with("round", (1..=rounds.len() as i64).collect::<Vec<i64>>())
        .with(
            "n_vectors",
            rounds
                .iter()
                .map(|round| round.n_vectors as i64)
                .collect::<Vec<i64>>(),
        )
        .with(
            "n_reduced",
            rounds
                .iter()
                .map(|round| round.n_reduced as i64)
                .collect::<Vec<i64>>(),
        )
        .with(
            "indicator",
            rounds
                .iter()
                .map(|round| round.indicator)
                .collect::<Vec<f64>>(),
        )
}

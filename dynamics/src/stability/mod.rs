//! `stability`: complex eigenvalues of the brake linearised about its sliding equilibrium
//! (`docs/science.md` §4).
//!
//! Perturbations keep every closed pair in contact and sliding ([`sliding`]):
//!
//! ```text
//! (λ² M̃ + λ C̃ + K̃) q = 0,   (M̃, C̃, K̃) = Tᵘᵀ (M, Ĉ, K) Tᴺ,   u = Tᴺ q
//! ```
//!
//! with Tᴺ a basis of W⁰ (no relative normal displacement on the contact zone) and Tᵘ of W^μ
//! (test functions on which the friction-coupled contact force does no work). Friction makes
//! the problem non-symmetric; a pair of modes that coalesce can give an eigenvalue with
//! `Re λ > 0`: an **unstable** mode, growing like `e^{Re λ t}`, the squeal candidate.
//!
//! Reported per eigenvalue (upper half plane only; conjugates are implied):
//!
//! ```text
//! freq_hz = Im λ / 2π,   divergence_rate = 2 Re λ / Im λ   (a negative damping ratio)
//! residual = ‖(λ² M̃ + λ C̃ + K̃) q‖ / ((|λ|² ‖M̃‖₁ + |λ| ‖C̃‖₁ + ‖K̃‖₁) ‖q‖)
//! ```
//!
//! (the norms are those of the symmetric parts Tᴺᵀ(·)Tᴺ). A mode is unstable when
//! `Re λ > 1e-8 |λ|`, above the round-off of a conservative system.
//!
//! Methods:
//! - `krylov` (reference): every eigenvalue with `0 < f ≤ f_max_hz` and
//!   `|divergence rate| ≤ max_divergence_rate`, by shift-invert block Arnoldi at as many
//!   shifts as needed, the overlaps of their trusted disks checked ([`krylov`]). Systems of
//!   up to `DENSE_LIMIT` DOFs are solved densely instead ([`dense`]).
//! - `real_mode_projection` (fast, approximate, as industrial codes do): the real modes Φ of
//!   the conservative μ = 0 sliding structure (`Tᴺᵀ K Tᴺ φ = ω² Tᴺᵀ M Tᴺ φ`, block Lanczos with
//!   a Sturm count) form a reduced basis, `(Φᵀ M̃ Φ, Φᵀ C̃ Φ, Φᵀ K̃ Φ)` is solved densely and each
//!   approximate pair is given its residual in the full problem.
//!
//! Mode shapes `u = Tᴺ q` are normalised to `uᴴ M u = 1` with their largest component real
//! and positive.

pub mod conditioning;
pub mod dense;
mod figure;
pub mod krylov;
pub mod matrices;
pub mod shift_invert;
pub mod sliding;
pub mod track;

#[cfg(test)]
mod tests;

use std::f64::consts::PI;

use faer::c64;

use crate::artifact::Equilibrium;
use crate::artifact::Model;
use crate::artifact::{Artifact, ArtifactType, ComplexMode, ComplexModes, ComplexShape};
use crate::stage::{
    HasParams, Inputs, Outputs, Params, PortSpec, Progress, Resources, RunContext, Stage,
    StageError,
};
use crate::table::Table;
use squeal_linalg::eigensolver::{self, Band, SolveOptions};
use squeal_linalg::ldlt::ShiftedPencil;

pub use krylov::{EigenPair, KrylovOptions};
use sliding::{Part, SlidingSystem, mul_complex};

/// Systems of up to this many reduced DOFs are solved densely (an eigenproblem of size 2·DOFs).
pub const DENSE_LIMIT: usize = 300;
/// With `n_real_modes = 0`, the projection keeps every real mode below this multiple of f_max.
pub const PROJECTION_BAND_FACTOR: f64 = 1.5;

crate::choice! {
    /// Which [`Method`] solves the band, by the name a study gives it.
    pub enum MethodKind {
        /// Shift-invert Arnoldi over the band (the reference).
        Krylov = "krylov",
        /// Projection on real modes (fast, approximate).
        RealModeProjection = "real_mode_projection",
    }
}

crate::choice! {
    /// Which mode shapes go to the shapes table.
    pub enum ShapesKept {
        All = "all",
        Unstable = "unstable",
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Method {
    Krylov,
    /// Projection on the lowest `n_real_modes` real modes (0: all below 1.5 f_max).
    RealModeProjection {
        n_real_modes: usize,
    },
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    pub method: Method,
    pub f_max_hz: f64,
    pub max_divergence_rate: f64,
    pub friction_damping: bool,
    pub krylov: KrylovOptions,
    /// Reduced systems up to this size are solved densely by `krylov` (0: never).
    pub dense_limit: usize,
    /// Also solve the transposed problem for the left eigenvectors: each eigenvalue's
    /// condition number (always, when solved densely).
    pub condition_numbers: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            method: Method::Krylov,
            f_max_hz: 17_000.0,
            max_divergence_rate: 0.1,
            friction_damping: true,
            krylov: KrylovOptions::default(),
            dense_limit: DENSE_LIMIT,
            condition_numbers: false,
        }
    }
}

/// Figures of a solve (for the summary and benchmarks).
#[derive(Debug, Clone, Default)]
pub struct SolveReport {
    pub dense: bool,
    pub band: krylov::BandReport,
    /// Real modes used by the projection.
    pub real_modes: usize,
    /// Modes of the undamped μ = 0 sliding structure below f_max (Sturm count): the size the
    /// band has without friction coupling and damping.
    pub conservative_count: usize,
}

/// The eigenpairs in the band, by increasing frequency, with the system they belong to.
pub struct Solution {
    pub system: SlidingSystem,
    pub pairs: Vec<EigenPair>,
    pub report: SolveReport,
}

/// Whether `lambda` lies in the band of `settings`: `0 < Im λ ≤ 2π f_max` and
/// `2 |Re λ| ≤ max_divergence_rate · Im λ`.
pub fn in_band(lambda: c64, settings: &Settings) -> bool {
    let omega_max = 2.0 * PI * settings.f_max_hz;
    lambda.im > 0.0
        && lambda.im <= omega_max
        && 2.0 * lambda.re.abs() <= settings.max_divergence_rate * lambda.im
}

/// Solves the stability problem of `model` about `equilibrium`.
pub fn solve(
    model: &Model,
    equilibrium: &Equilibrium,
    settings: &Settings,
) -> Result<Solution, StageError> {
    solve_with_progress(model, equilibrium, settings, &Progress::none())
}

/// [`solve`], reporting the fraction of the band covered to `progress`.
pub fn solve_with_progress(
    model: &Model,
    equilibrium: &Equilibrium,
    settings: &Settings,
    progress: &Progress,
) -> Result<Solution, StageError> {
    if !(settings.f_max_hz > 0.0) {
        return Err(StageError::new(format!(
            "f_max_hz = {} must be positive",
            settings.f_max_hz
        )));
    }
    if !equilibrium.closed.iter().any(|closed| *closed) {
        return Err(StageError::new(
            "no contact pair is closed at equilibrium: there is no sliding contact to linearise",
        ));
    }
    let system = SlidingSystem::new(model, equilibrium, settings.friction_damping)?;
    let omega_max = 2.0 * PI * settings.f_max_hz;
    let mut report = SolveReport {
        conservative_count: conservative_count(&system, omega_max * omega_max)?,
        ..SolveReport::default()
    };
    tracing::info!(
        "stability: {} DOFs after slave elimination; the undamped μ = 0 structure has {} modes below {} Hz",
        system.dim(),
        report.conservative_count,
        settings.f_max_hz
    );
    let pairs = match settings.method {
        Method::Krylov if system.dim() <= settings.dense_limit => {
            report.dense = true;
            let [M, C, K] = dense::dense_matrices(&system);
            dense::quadratic_eigen(M.as_ref(), C.as_ref(), K.as_ref(), |lambda| {
                in_band(lambda, settings)
            })?
            .into_iter()
            .map(|(lambda, q)| pair_with_residual(&system, lambda, q))
            .collect()
        }
        Method::Krylov => {
            // With condition numbers, the band is covered twice: this solve is the first half.
            let share = if settings.condition_numbers { 0.5 } else { 1.0 };
            let (pairs, band) = krylov::solve_band(
                &system,
                omega_max,
                settings.max_divergence_rate,
                &settings.krylov,
                &|fraction| band_progress(progress, share * fraction, "the band covered"),
            )?;
            report.band = band;
            pairs
        }
        Method::RealModeProjection { n_real_modes } => {
            let (pairs, n_modes) = project_on_real_modes(&system, n_real_modes, settings)?;
            report.real_modes = n_modes;
            pairs
        }
    };
    let mut pairs: Vec<EigenPair> = pairs;
    pairs.sort_by(|a, b| a.lambda.im.total_cmp(&b.lambda.im));
    if matches!(settings.method, Method::Krylov)
        && let Some(worst) = pairs
            .iter()
            .find(|pair| !(pair.residual <= settings.krylov.residual_tolerance))
    {
        return Err(StageError::new(format!(
            "the eigenvalue at {:.2} Hz has residual {:.2e} > {:e}",
            worst.lambda.im / (2.0 * PI),
            worst.residual,
            settings.krylov.residual_tolerance
        )));
    }
    if settings.method == Method::Krylov && (report.dense || settings.condition_numbers) {
        let left = left_eigenpairs(&system, settings, report.dense, progress)?;
        let conditions =
            conditioning::condition_numbers(&pairs, &left, system.norms, |lambda, y, x| {
                system.derivative_form(lambda, y, x)
            });
        conditioning::attach(&mut pairs, conditions);
    }
    Ok(Solution {
        system,
        pairs,
        report,
    })
}

fn band_progress(progress: &Progress, fraction: f64, what: &str) {
    tracing::info!("stability: {:.0} % of {what}", 100.0 * fraction);
    progress.report(fraction, &format!("{:.0} % of {what}", 100.0 * fraction));
}

/// The eigenpairs of the transposed problem (their vectors are the left eigenvectors), by
/// the solver that found the right ones, on a band a hair wider so that an eigenvalue at its
/// edge finds its twin.
fn left_eigenpairs(
    system: &SlidingSystem,
    settings: &Settings,
    dense: bool,
    progress: &Progress,
) -> Result<Vec<EigenPair>, StageError> {
    let transposed = system.transposed();
    let wider = Settings {
        f_max_hz: settings.f_max_hz * (1.0 + 1e-6),
        max_divergence_rate: settings.max_divergence_rate * (1.0 + 1e-6),
        ..*settings
    };
    if dense {
        let [M, C, K] = dense::dense_matrices(&transposed);
        return Ok(
            dense::quadratic_eigen(M.as_ref(), C.as_ref(), K.as_ref(), |lambda| {
                in_band(lambda, &wider)
            })?
            .into_iter()
            .map(|(lambda, q)| EigenPair {
                lambda,
                q,
                residual: f64::NAN,
                condition: f64::NAN,
            })
            .collect(),
        );
    }
    let (pairs, _) = krylov::solve_band(
        &transposed,
        2.0 * PI * wider.f_max_hz,
        wider.max_divergence_rate,
        &settings.krylov,
        &|fraction| {
            band_progress(
                progress,
                0.5 + 0.5 * fraction,
                "the transposed band covered (condition numbers)",
            )
        },
    )?;
    Ok(pairs)
}

fn pair_with_residual(system: &SlidingSystem, lambda: c64, q: Vec<c64>) -> EigenPair {
    let residual = system.residual(lambda, &q);
    EigenPair {
        lambda,
        q,
        residual,
        condition: f64::NAN,
    }
}

/// Eigenvalues of `Tᴺᵀ K Tᴺ − ω² Tᴺᵀ M Tᴺ` below `lambda` (negative pivots of its LDLᵀ).
fn conservative_count(system: &SlidingSystem, lambda: f64) -> Result<usize, StageError> {
    let pencil = ShiftedPencil::new(&system.K_sym, &system.M_sym, &system.dof_of_node)?;
    Ok(pencil.factor(lambda, squeal_linalg::par())?.negative_pivots)
}

/// The real-mode projection: Galerkin on the lowest real modes of the μ = 0 structure, tested
/// with their images in W^μ.
fn project_on_real_modes(
    system: &SlidingSystem,
    n_real_modes: usize,
    settings: &Settings,
) -> Result<(Vec<EigenPair>, usize), StageError> {
    let omega_hi = 2.0 * PI * settings.f_max_hz * PROJECTION_BAND_FACTOR;
    let band = Band {
        n_modes: n_real_modes,
        lambda_lo: 0.0,
        lambda_hi: if n_real_modes == 0 {
            omega_hi * omega_hi
        } else {
            f64::INFINITY
        },
    };
    let real = eigensolver::solve(
        &system.K_sym,
        &system.M_sym,
        &system.dof_of_node,
        band,
        SolveOptions::default(),
    )?;
    let Phi = real.shapes;
    let n_modes = Phi.ncols();
    if n_modes == 0 {
        return Err(StageError::new(
            "the real-mode projection has no real mode to project on",
        ));
    }
    let reduced = |part: Part| Phi.transpose() * dense::reduced_times(system, part, Phi.as_ref());
    let (M, C, K) = (reduced(Part::M), reduced(Part::C), reduced(Part::K));
    let pairs = dense::quadratic_eigen(M.as_ref(), C.as_ref(), K.as_ref(), |lambda| {
        in_band(lambda, settings)
    })?
    .into_iter()
    .map(|(lambda, eta)| {
        let q: Vec<c64> = (0..system.dim())
            .map(|row| (0..n_modes).map(|mode| eta[mode] * Phi[(row, mode)]).sum())
            .collect();
        pair_with_residual(system, lambda, q)
    })
    .collect();
    Ok((pairs, n_modes))
}

/// The full-DOF shape `u = Tᴺ q`, scaled to `uᴴ M u = 1` with its largest component real
/// and positive.
pub fn mode_shape(system: &SlidingSystem, q: &[c64]) -> Vec<c64> {
    let u = system.expand(q);
    let Mu = mul_complex(&system.M, &u);
    let mass: f64 = u.iter().zip(&Mu).map(|(a, b)| (a.conj() * b).re).sum();
    let largest = u
        .iter()
        .copied()
        .max_by(|a, b| a.norm().total_cmp(&b.norm()))
        .unwrap_or(c64::new(1.0, 0.0));
    let phase = if largest.norm() > 0.0 {
        largest.conj() / largest.norm()
    } else {
        c64::new(1.0, 0.0)
    };
    let scale = phase / mass.max(f64::MIN_POSITIVE).sqrt();
    u.into_iter().map(|value| value * scale).collect()
}

/// Per eigenvalue of `reference`, the relative distance `|λ' − λ| / |λ|` to the nearest one
/// of `approximate` (how far an approximate method lands from the reference).
pub fn nearest_relative_errors(reference: &[EigenPair], approximate: &[EigenPair]) -> Vec<f64> {
    reference
        .iter()
        .map(|pair| {
            approximate
                .iter()
                .map(|other| (other.lambda - pair.lambda).norm() / pair.lambda.norm())
                .fold(f64::INFINITY, f64::min)
        })
        .collect()
}

pub fn divergence_rate(lambda: c64) -> f64 {
    2.0 * lambda.re / lambda.im
}

pub use crate::artifact::complex_modes::is_unstable;

/// The eigenpair `pair`, the `mode`-th (0-based) of its band, with its shape over the model's
/// DOFs when it is kept.
pub fn complex_mode(
    mode: usize,
    pair: &EigenPair,
    shape: Option<(Vec<f64>, Vec<f64>)>,
) -> ComplexMode {
    ComplexMode {
        number: mode as i64 + 1,
        re: pair.lambda.re,
        im: pair.lambda.im,
        residual: pair.residual,
        condition: pair.condition,
        shape: shape.map(|(re, im)| ComplexShape { re, im }),
    }
}

/// Name of the columns of mode `mode` (0-based) in the shapes table, without `_re`/`_im`.
pub fn mode_name(mode: usize) -> String {
    format!("mode_{:04}", mode + 1)
}

/// `eigenvalues`: one row per eigenvalue in the band.
pub fn eigenvalue_table(pairs: &[EigenPair]) -> Table {
    let column = |f: &dyn Fn(&EigenPair) -> f64| pairs.iter().map(f).collect::<Vec<f64>>();
    Table::new()
        .with("mode", (1..=pairs.len() as i64).collect::<Vec<i64>>())
        .with("freq_hz", column(&|pair| pair.lambda.im / (2.0 * PI)))
        .with("re", column(&|pair| pair.lambda.re))
        .with("im", column(&|pair| pair.lambda.im))
        .with(
            "divergence_rate",
            column(&|pair| divergence_rate(pair.lambda)),
        )
        .with(
            "unstable",
            pairs
                .iter()
                .map(|pair| is_unstable(pair.lambda))
                .collect::<Vec<bool>>(),
        )
        .with("residual", column(&|pair| pair.residual))
        .with("condition", column(&|pair| pair.condition))
        .with(
            "error_bound",
            column(&|pair| pair.condition * pair.residual),
        )
}

/// The `stability` stage.
pub struct Stability;

crate::stage_params! {
    /// The parameters of `stability`.
    pub struct StabilityParams {
        /// shift-invert Arnoldi (reference), or projection on real modes (fast, approximate)
        method: MethodKind = MethodKind::Krylov,
        /// top of the band
        #[unit = "Hz"]
        #[min = 0.0]
        f_max_hz: f64 = Settings::default().f_max_hz,
        /// modes with |2 Re/Im| beyond this are not sought (squeal modes lie within a few %; a
        /// wider band needs wider disks, so a larger max_basis, at high frequency: 0.2 on the
        /// default brake to 17 kHz does not fit 960 vectors)
        #[min = 0.0]
        max_divergence_rate: f64 = Settings::default().max_divergence_rate,
        /// include the damping mu r_n / |v_g| of the friction direction
        friction_damping: bool = true,
        /// real_mode_projection: real modes in the basis (0: all below 1.5 f_max_hz)
        #[min = 0]
        n_real_modes: usize = 0,
        /// krylov: largest Arnoldi basis per shift (memory and time grow with it)
        #[min = 8]
        max_basis: usize = Settings::default().krylov.max_basis,
        /// which mode shapes go to the shapes table
        shapes: ShapesKept = ShapesKept::All,
        /// krylov: also solve densely (small models: a dense eigenproblem of twice the sliding
        /// DOFs, at most 6,000) and report in the summary how far each solve's eigenvalues are from
        /// the other's
        check_dense: bool = false,
        /// krylov: also solve the transposed problem (its eigenvectors are the left ones) for each
        /// eigenvalue's condition number and error bound, at twice the run time; systems solved
        /// densely always have them
        condition_numbers: bool = false,
    }
}

impl HasParams for Stability {
    type Params = StabilityParams;
}

impl Stage for Stability {
    fn kind(&self) -> &'static str {
        "stability"
    }
    fn version(&self) -> u32 {
        // 10: the `modes` output (CHANGELOG.md, "stability")
        10
    }
    fn doc(&self) -> &'static str {
        "Complex eigenvalues of the sliding equilibrium: every mode in the band, divergence rates, stability diagram"
    }
    fn resources(&self) -> Resources {
        Resources::job(4, 4096)
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
                "the sliding equilibrium to linearise about",
            ),
        ]
    }
    fn renamed_outputs(&self) -> &'static [(&'static str, &'static str)] {
        &[("unstable_vtu", "unstable_modes")]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "eigenvalues",
                ArtifactType::Table,
                "mode, freq_hz, re, im, divergence_rate, unstable, residual, condition (κ: NaN where not computed), error_bound (κ × residual: relative error of λ)",
            ),
            PortSpec::one(
                "shapes",
                ArtifactType::Table,
                "one row per node and direction, mode_NNNN_re and mode_NNNN_im columns",
            ),
            PortSpec::one(
                "modes",
                ArtifactType::ComplexModes,
                "every eigenvalue with its residual and κ, and the shapes kept: what basis, transient, svd_projection and stability.track take",
            ),
            PortSpec::one(
                "summary",
                ArtifactType::Table,
                "method, counts, worst residual, shifts",
            ),
            PortSpec::one(
                "diagram",
                ArtifactType::Figure,
                "stability diagram: divergence rate against frequency",
            ),
            PortSpec::one(
                "unstable_modes",
                ArtifactType::Document,
                "unstable mode shapes (real and imaginary parts) for ParaView",
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
        let model: &Model = inputs.get("model")?;
        let equilibrium: &Equilibrium = inputs.get("equilibrium")?;
        let params = params.read::<Self>()?;
        let method = match params.method {
            MethodKind::Krylov => Method::Krylov,
            MethodKind::RealModeProjection => Method::RealModeProjection {
                n_real_modes: params.n_real_modes,
            },
        };
        let settings = Settings {
            method,
            f_max_hz: params.f_max_hz,
            max_divergence_rate: params.max_divergence_rate,
            friction_damping: params.friction_damping,
            krylov: KrylovOptions {
                max_basis: params.max_basis,
                ..KrylovOptions::default()
            },
            dense_limit: DENSE_LIMIT,
            condition_numbers: params.condition_numbers,
        };
        let solution = solve_with_progress(model, equilibrium, &settings, context.progress)?;
        let dense_check = if params.check_dense && method == Method::Krylov {
            Some(against_dense(&solution, &settings)?)
        } else {
            None
        };
        let shapes: Vec<Vec<c64>> = solution
            .pairs
            .iter()
            .map(|pair| mode_shape(&solution.system, &pair.q))
            .collect();
        let only_unstable = params.shapes == ShapesKept::Unstable;
        let mut fields = Vec::new();
        let mut unstable_fields = Vec::new();
        let mut modes = Vec::with_capacity(shapes.len());
        for (mode, (pair, shape)) in solution.pairs.iter().zip(&shapes).enumerate() {
            let real: Vec<f64> = shape.iter().map(|value| value.re).collect();
            let imaginary: Vec<f64> = shape.iter().map(|value| value.im).collect();
            let unstable = is_unstable(pair.lambda);
            if unstable {
                unstable_fields.push((
                    format!("{}_{:.0}Hz", mode_name(mode), pair.lambda.im / (2.0 * PI)),
                    real.clone(),
                    imaginary.clone(),
                ));
            }
            let kept = unstable || !only_unstable;
            if kept {
                fields.push((format!("{}_re", mode_name(mode)), real.clone()));
                fields.push((format!("{}_im", mode_name(mode)), imaginary.clone()));
            }
            modes.push(complex_mode(mode, pair, kept.then_some((real, imaginary))));
        }
        let shapes_table = model.nodal_table(fields);
        let vtu = crate::vtu_writer::complex_modes_vtu(model, &unstable_fields)?;
        let diagram = figure::stability_diagram(&solution.pairs, equilibrium.mu)?;
        Ok(Outputs::from([
            (
                "eigenvalues".to_string(),
                Artifact::Table(eigenvalue_table(&solution.pairs)),
            ),
            ("shapes".to_string(), Artifact::Table(shapes_table)),
            (
                "modes".to_string(),
                Artifact::ComplexModes(Box::new(ComplexModes { modes })),
            ),
            (
                "summary".to_string(),
                Artifact::Table(summary_table(&solution, &settings, dense_check)),
            ),
            ("diagram".to_string(), Artifact::Figure(diagram)),
            ("unstable_modes".to_string(), Artifact::document("vtu", vtu)),
        ]))
    }
}

/// How a Krylov solve compares with the dense solve of the same problem.
#[derive(Debug, Clone, Copy)]
struct DenseCheck {
    /// Eigenvalues the dense solve finds in the band.
    eigenvalues: usize,
    /// Largest relative distance from an eigenvalue of either solve to the other's nearest: a
    /// missed or spurious eigenvalue shows as a large distance.
    distance: f64,
}

/// Largest sliding problem `check_dense` solves.
const DENSE_CHECK_LIMIT: usize = 3000;

/// The dense solve of `solution`'s problem, against its eigenvalues. Each direction looks at
/// the other solve's eigenvalues on a band a hair wider, so that one at the band's edge is
/// not counted as missed.
fn against_dense(solution: &Solution, settings: &Settings) -> Result<DenseCheck, StageError> {
    let system = &solution.system;
    if system.dim() > DENSE_CHECK_LIMIT {
        return Err(StageError::new(format!(
            "check_dense: {} sliding DOFs, the dense check takes at most {DENSE_CHECK_LIMIT}",
            system.dim()
        )));
    }
    let scaled = |factor: f64| Settings {
        f_max_hz: settings.f_max_hz * factor,
        max_divergence_rate: settings.max_divergence_rate * factor,
        ..*settings
    };
    let (wider, narrower) = (scaled(1.0 + 1e-6), scaled(1.0 - 1e-6));
    let [M, C, K] = dense::dense_matrices(system);
    let dense: Vec<EigenPair> =
        dense::quadratic_eigen(M.as_ref(), C.as_ref(), K.as_ref(), |lambda| {
            in_band(lambda, &wider)
        })?
        .into_iter()
        .map(|(lambda, q)| pair_with_residual(system, lambda, q))
        .collect();
    let inner: Vec<EigenPair> = dense
        .iter()
        .filter(|pair| in_band(pair.lambda, &narrower))
        .cloned()
        .collect();
    let distance = nearest_relative_errors(&solution.pairs, &dense)
        .into_iter()
        .chain(nearest_relative_errors(&inner, &solution.pairs))
        .fold(0.0, f64::max);
    Ok(DenseCheck {
        eigenvalues: dense
            .iter()
            .filter(|pair| in_band(pair.lambda, settings))
            .count(),
        distance,
    })
}

fn summary_table(solution: &Solution, settings: &Settings, check: Option<DenseCheck>) -> Table {
    let pairs = &solution.pairs;
    let report = &solution.report;
    let worst = pairs.iter().map(|pair| pair.residual).fold(0.0, f64::max);
    let mut quantities: Vec<(&str, f64)> = vec![
        ("dofs", solution.system.full_dim() as f64),
        ("sliding_dofs", solution.system.dim() as f64),
        ("closed_pairs", solution.system.slaves.len() as f64),
        ("f_max_hz", settings.f_max_hz),
        ("eigenvalues", pairs.len() as f64),
        (
            "unstable",
            pairs.iter().filter(|pair| is_unstable(pair.lambda)).count() as f64,
        ),
        (
            "max_divergence_rate_found",
            pairs
                .iter()
                .map(|pair| divergence_rate(pair.lambda))
                .fold(f64::NEG_INFINITY, f64::max),
        ),
        ("worst_residual", worst),
        // NaN when the condition numbers were not computed.
        (
            "max_error_bound",
            pairs
                .iter()
                .map(|pair| pair.condition * pair.residual)
                .fold(f64::NAN, f64::max),
        ),
        (
            "conservative_modes_below_f_max",
            report.conservative_count as f64,
        ),
        ("shifts", report.band.shifts.len() as f64),
        ("real_modes", report.real_modes as f64),
        ("dense", f64::from(u8::from(report.dense))),
    ];
    if let Some(check) = check {
        quantities.push(("dense_eigenvalues", check.eigenvalues as f64));
        quantities.push(("distance_to_dense", check.distance));
    }
    let method = match settings.method {
        Method::Krylov => "krylov",
        Method::RealModeProjection { .. } => "real_mode_projection",
    };
    Table::quantities(&quantities).with("method", vec![method.to_string(); quantities.len()])
}

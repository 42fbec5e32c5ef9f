//! The condensed solve: K factorised (floating bodies pinned), the contact problem condensed
//! on the pairs, the LCP solved there, the displacement lifted back.

use faer::Mat;
use squeal_linalg::ldlt::{Factor, ShiftedPencil};

use super::floating::check_contact_holds;
use super::floating::{
    AppliedPressure, Floating, PressureOn, body_list, floating_under_pressure, pin,
};
use crate::artifact::{ContactFrames, Equilibrium, Model};
use crate::contact;
use crate::contact::lcp::{self, Balance, LcpSettings, LcpSolution};
use crate::stage::StageError;

crate::choice! {
    /// The solver of the condensed contact problem.
    pub enum Solver {
        /// Semi-smooth Newton on the complementarity function.
        SemismoothNewton = "newton",
        /// The paper's projected fixed point.
        FixedPoint = "fixed_point",
    }
}

/// What presses the pads onto the disc.
#[derive(Debug, Clone, PartialEq)]
pub enum Load {
    /// Clamped backs pushed toward the disc by this much (m).
    Interference(f64),
    /// Pressures on the boundary faces of node sets (the pad backs, the pistons' faces), the
    /// bodies they push free along the normal.
    Pressure(Vec<PressureOn>),
}

impl Load {
    /// `pressure` (Pa) on the pad backs ([`PRESSURE_SET`](super::floating::PRESSURE_SET)).
    pub fn on_pad_backs(pressure: f64) -> Load {
        Load::Pressure(vec![PressureOn {
            set: super::floating::PRESSURE_SET.to_string(),
            pressure,
        }])
    }
}

/// What the solve reports besides the equilibrium.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    pub solver: Solver,
    pub load: Load,
    /// With a pressure load: what it applies.
    pub applied: Option<AppliedPressure>,
    pub lcp: LcpSolution,
    /// ‖K u − F − Gᵀ r‖ / ‖F + Gᵀ r‖ of the returned state.
    pub equation_residual: f64,
    /// Wall time (s) of the factorisation of K, of the condensation (solves and A = H_n Z),
    /// and of the contact iterations. For benchmarks only: never part of an output.
    pub seconds: [f64; 3],
}

/// Solves the sliding equilibrium of `model`: K factorised (floating bodies pinned), the
/// problem condensed on the pairs, the LCP solved there, the displacement lifted back and the
/// equation `K u = F + Gᵀ r` checked.
pub fn solve(
    model: &Model,
    mu: f64,
    omega: f64,
    load: Load,
    solver: Solver,
    settings: &LcpSettings,
) -> Result<(Equilibrium, Report), StageError> {
    let mesh = &model.mesh;
    if mesh.contact_pairs.is_empty() {
        return Err(StageError::new("the mesh has no contact pairs"));
    }
    let frames = contact::frames(mesh, omega).map_err(StageError::new)?;
    let columns = contact::h_columns(model, &frames);

    let clock = std::time::Instant::now();
    let (floating, interference) = match &load {
        Load::Interference(delta) => (None, *delta),
        Load::Pressure(pressures) => (Some(floating_under_pressure(model, pressures)?), 0.0),
    };
    let pinned_K = floating
        .as_ref()
        .map(|floating| pin(&model.K, &floating.pinned));
    let pencil = ShiftedPencil::new(
        pinned_K.as_ref().unwrap_or(&model.K),
        &model.M,
        &model.dof_of_node,
    )?;
    let factor = factor_stiffness(&pencil, floating.as_ref())?;
    let factor_seconds = clock.elapsed().as_secs_f64();

    let clock = std::time::Instant::now();
    let condensed = Condensed::new(
        model,
        &frames,
        &columns,
        mu,
        interference,
        floating.as_ref(),
        &factor,
    )?;
    let condense_seconds = clock.elapsed().as_secs_f64();

    let clock = std::time::Instant::now();
    let (A, q, balance) = (&condensed.A, &condensed.q, &condensed.balance);
    let lcp = match solver {
        Solver::FixedPoint => lcp::fixed_point_balanced(A, q, balance, settings),
        Solver::SemismoothNewton => lcp::semismooth_newton_balanced(A, q, balance, settings),
    }
    .map_err(|err| StageError::new(err.to_string()))?;
    let iterate_seconds = clock.elapsed().as_secs_f64();

    let u = condensed.displacement(&lcp, floating.as_ref());
    let equation_residual = equation_residual(model, &columns, mu, floating.as_ref(), &lcp, &u);
    let closed: Vec<bool> = lcp.r.iter().map(|r| *r > 0.0).collect();
    let equilibrium = Equilibrium {
        u,
        r_n: lcp.r.clone(),
        gap: lcp.g.clone(),
        closed,
        frames,
        mu,
        omega,
    };
    let seconds = [factor_seconds, condense_seconds, iterate_seconds];
    Ok((
        equilibrium,
        Report {
            solver,
            load,
            applied: floating.map(|floating| floating.applied),
            lcp,
            equation_residual,
            seconds,
        },
    ))
}

/// K (with the floating bodies pinned) factorised, or why it cannot be.
fn factor_stiffness<'p>(
    pencil: &'p ShiftedPencil,
    floating: Option<&Floating>,
) -> Result<Factor<'p>, StageError> {
    let factor = pencil
        .factor(0.0, squeal_linalg::par())
        .map_err(|err| match floating {
            None => StageError::from(err),
            Some(floating) => StageError::new(format!(
                "K with the floating bodies pinned cannot be factorised ({err}); floating: {}",
                body_list(&floating.bodies)
            )),
        })?;
    if factor.negative_pivots > 0 {
        return Err(StageError::new(match floating {
            None => format!(
                "K is not positive definite ({} negative pivots): a part is not supported — clamp the hub and the pad backs",
                factor.negative_pivots
            ),
            Some(floating) => format!(
                "K with the floating bodies pinned is not positive definite ({} negative pivots): a body has a mechanism other than its rigid motions, unsupported; floating: {}",
                factor.negative_pivots,
                body_list(&floating.bodies)
            ),
        }));
    }
    Ok(factor)
}

/// The problem condensed on the pairs: `A r + q = g ≥ 0 ⊥ r ≥ 0`, with the floating bodies'
/// balance, and `Z` to lift a solution back to the DOFs.
struct Condensed<'a> {
    columns: &'a [Vec<(usize, f64)>],
    /// `Z = S Gᵀ` (one column per pair), and `S F` in the last column under pressure; `S` is
    /// K⁻¹ without floating bodies, else the pinned solve (zero at the pinned DOFs).
    Z: Mat<f64>,
    A: Mat<f64>,
    q: Vec<f64>,
    balance: Balance,
}

impl<'a> Condensed<'a> {
    fn new(
        model: &Model,
        frames: &ContactFrames,
        columns: &'a [Vec<(usize, f64)>],
        mu: f64,
        interference: f64,
        floating: Option<&Floating>,
        factor: &Factor,
    ) -> Result<Condensed<'a>, StageError> {
        let mesh = &model.mesh;
        let (n, n_pairs) = (model.n_dofs(), mesh.contact_pairs.len());
        let normal = |pair: usize| &columns[3 * pair];
        let tangent = |pair: usize| &columns[3 * pair + 1];
        let mut Z = Mat::<f64>::zeros(n, n_pairs + usize::from(floating.is_some()));
        for pair in 0..n_pairs {
            for &(dof, value) in normal(pair) {
                Z[(dof, pair)] += value;
            }
            for &(dof, value) in tangent(pair) {
                Z[(dof, pair)] += mu * value;
            }
        }
        if let Some(floating) = floating {
            for (dof, force) in floating.forces.iter().enumerate() {
                Z[(dof, n_pairs)] = *force;
            }
            for &dof in &floating.pinned {
                Z.row_mut(dof).fill(0.0);
            }
        }
        factor.solve_in_place(Z.as_mut(), squeal_linalg::par());
        if let Some(floating) = floating {
            for &dof in &floating.pinned {
                Z.row_mut(dof).fill(0.0);
            }
        }
        let apply_normal = |pair: usize, vectors: &Mat<f64>, col: usize| {
            normal(pair)
                .iter()
                .map(|&(dof, value)| value * vectors[(dof, col)])
                .sum::<f64>()
        };
        let A = Mat::from_fn(n_pairs, n_pairs, |pair, col| apply_normal(pair, &Z, col));
        let q: Vec<f64> = (0..n_pairs)
            .map(|pair| {
                let g0 = crate::contact::initial_gap(
                    &mesh.contact_pairs[pair],
                    &mesh.nodes,
                    frames.n[pair],
                );
                match floating {
                    None => g0 - interference,
                    Some(_) => g0 + apply_normal(pair, &Z, n_pairs),
                }
            })
            .collect();
        let balance = match floating {
            None => Balance::none(n_pairs),
            Some(floating) => {
                let R = &floating.R;
                let m = R.ncols();
                let apply_g = |pair: usize, mode: usize| {
                    apply_normal(pair, R, mode)
                        + mu * tangent(pair)
                            .iter()
                            .map(|&(dof, value)| value * R[(dof, mode)])
                            .sum::<f64>()
                };
                let balance = Balance {
                    B: Mat::from_fn(n_pairs, m, |pair, mode| apply_normal(pair, R, mode)),
                    C: Mat::from_fn(n_pairs, m, apply_g),
                    d: (0..m)
                        .map(|mode| {
                            -(0..n)
                                .map(|dof| R[(dof, mode)] * floating.forces[dof])
                                .sum::<f64>()
                        })
                        .collect(),
                };
                check_contact_holds(&balance.B, &floating.bodies)?;
                balance
            }
        };
        Ok(Condensed {
            columns,
            Z,
            A,
            q,
            balance,
        })
    }

    /// `u = Z r` (+ `S F` and the floating bodies' rigid motions `R a` under pressure).
    fn displacement(&self, lcp: &LcpSolution, floating: Option<&Floating>) -> Vec<f64> {
        let n_pairs = self.columns.len() / 3;
        let Z = &self.Z;
        (0..Z.nrows())
            .map(|dof| {
                let mut value = (0..n_pairs)
                    .map(|pair| Z[(dof, pair)] * lcp.r[pair])
                    .sum::<f64>();
                if let Some(floating) = floating {
                    value += Z[(dof, n_pairs)];
                    value += (0..lcp.a.len())
                        .map(|mode| floating.R[(dof, mode)] * lcp.a[mode])
                        .sum::<f64>();
                }
                value
            })
            .collect()
    }
}

/// `‖K u − F − Gᵀ r‖ / ‖F + Gᵀ r‖`, with K itself (not the pinned one).
fn equation_residual(
    model: &Model,
    columns: &[Vec<(usize, f64)>],
    mu: f64,
    floating: Option<&Floating>,
    lcp: &LcpSolution,
    u: &[f64],
) -> f64 {
    let mut rhs = match floating {
        None => vec![0.0; model.n_dofs()],
        Some(floating) => floating.forces.clone(),
    };
    for (pair, r) in lcp.r.iter().enumerate() {
        for &(dof, value) in &columns[3 * pair] {
            rhs[dof] += value * r;
        }
        for &(dof, value) in &columns[3 * pair + 1] {
            rhs[dof] += value * mu * r;
        }
    }
    let Ku = model.K.mul_vec(u);
    let norm = |v: &[f64]| v.iter().map(|value| value * value).sum::<f64>().sqrt();
    let difference: Vec<f64> = Ku.iter().zip(&rhs).map(|(a, b)| a - b).collect();
    norm(&difference) / norm(&rhs).max(f64::MIN_POSITIVE)
}

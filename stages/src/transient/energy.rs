//! The energy audit of the θ-method, step by step.
//!
//! Multiplying the step's equation by `τ v^θ = u¹ − u⁰` and using
//! `x^θ = ½(x¹ + x⁰) + (θ − ½)(x¹ − x⁰)` gives the exact discrete identity
//!
//! ```text
//! ΔT + ΔE = τ (r − r_e)·w^θ − τ v^θ·C v^θ − (θ − ½)(Δvᵀ M Δv + Δuᵀ K Δu)
//! ```
//!
//! with `T = ½ vᵀ M v`, `E = ½ uᵀ K u` (strain energy of the departure from the equilibrium),
//! `w = H v` the pairs' relative velocities. The terms, accumulated from the start:
//! - `viscous`: Rayleigh damping's dissipation (≥ 0);
//! - `scheme`: the θ-method's own dissipation, zero for θ = ½ (≥ 0);
//! - the work of the contact reactions in excess of the equilibrium's, split per pair as
//!   `drive` (the disc's sliding velocity: `(r_t − r_e,t) v_g`, where squeal gets its energy),
//!   `friction` (against the slip `s = (w_t − v_g, w_b)`) and `normal` (impacts, separations).
//!
//! The imposed loads are constant: their work against the departure is balanced by the
//! equilibrium's reactions, which is why the reactions enter as `r − r_e`. The balance error
//! `T + E − (T₀ + E₀) − (drive + friction + normal − viscous − scheme)` is zero up to
//! round-off and the accuracy of the solves: it is the audit's verdict.

/// Accumulated energies and works (J) at one time.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Totals {
    pub kinetic: f64,
    pub strain: f64,
    pub viscous: f64,
    pub scheme: f64,
    pub drive: f64,
    pub friction: f64,
    pub normal: f64,
    pub balance_error: f64,
}

/// The running audit.
pub struct Audit {
    initial: f64,
    pub totals: Totals,
}

/// What one step contributes: the states before and after, with their products.
pub struct StepWork<'a> {
    pub tau: f64,
    pub theta: f64,
    pub u_old: &'a [f64],
    pub u_new: &'a [f64],
    pub v_old: &'a [f64],
    pub v_new: &'a [f64],
    /// `(M v, C v, K v)` per DOF before and after.
    pub MCK_v_old: &'a [[f64; 3]],
    pub MCK_v_new: &'a [[f64; 3]],
    pub K_u_old: &'a [f64],
    pub K_u_new: &'a [f64],
    /// Reactions of the step and at the equilibrium, three per pair (n, t, b).
    pub r: &'a [f64],
    pub r_e: &'a [f64],
    /// Relative velocities of the pairs before and after.
    pub w_old: &'a [f64],
    pub w_new: &'a [f64],
    pub sliding_speed: &'a [f64],
}

fn dot(a: impl Iterator<Item = f64>, b: impl Iterator<Item = f64>) -> f64 {
    a.zip(b).map(|(x, y)| x * y).sum()
}

impl Audit {
    pub fn new(u: &[f64], v: &[f64], MCK_v: &[[f64; 3]], K_u: &[f64]) -> Audit {
        let kinetic = 0.5 * dot(v.iter().copied(), MCK_v.iter().map(|p| p[0]));
        let strain = 0.5 * dot(u.iter().copied(), K_u.iter().copied());
        Audit {
            initial: kinetic + strain,
            totals: Totals {
                kinetic,
                strain,
                ..Totals::default()
            },
        }
    }

    pub fn step(&mut self, work: StepWork) {
        let StepWork { tau, theta, .. } = work;
        let totals = &mut self.totals;
        totals.kinetic = 0.5
            * dot(
                work.v_new.iter().copied(),
                work.MCK_v_new.iter().map(|p| p[0]),
            );
        totals.strain = 0.5 * dot(work.u_new.iter().copied(), work.K_u_new.iter().copied());
        let mid = |new: f64, old: f64| theta * new + (1.0 - theta) * old;
        totals.viscous += tau
            * dot(
                work.v_new.iter().zip(work.v_old).map(|(a, b)| mid(*a, *b)),
                work.MCK_v_new
                    .iter()
                    .zip(work.MCK_v_old)
                    .map(|(a, b)| mid(a[1], b[1])),
            );
        let mass_part = dot(
            work.v_new.iter().zip(work.v_old).map(|(a, b)| a - b),
            work.MCK_v_new
                .iter()
                .zip(work.MCK_v_old)
                .map(|(a, b)| a[0] - b[0]),
        );
        let stiffness_part = dot(
            work.u_new.iter().zip(work.u_old).map(|(a, b)| a - b),
            work.K_u_new.iter().zip(work.K_u_old).map(|(a, b)| a - b),
        );
        totals.scheme += (theta - 0.5) * (mass_part + stiffness_part);
        for (p, &speed) in work.sliding_speed.iter().enumerate() {
            let k = 3 * p;
            let w_mid = [0, 1, 2].map(|d| mid(work.w_new[k + d], work.w_old[k + d]));
            let dr = [0, 1, 2].map(|d| work.r[k + d] - work.r_e[k + d]);
            totals.normal += tau * dr[0] * w_mid[0];
            totals.drive += tau * dr[1] * speed;
            totals.friction += tau * (dr[1] * (w_mid[1] - speed) + dr[2] * w_mid[2]);
        }
        totals.balance_error = totals.kinetic + totals.strain
            - self.initial
            - (totals.drive + totals.friction + totals.normal - totals.viscous - totals.scheme);
    }
}

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
//! - the work of the contact reactions, per pair: `drive = r_t v_g`, the power the turning disc
//!   feeds in through friction; `friction = r_T·s` with the slip `s = (w_t − v_g, w_b)`, what
//!   friction dissipates (≤ 0 while sliding); `normal = r_n w_n`, impacts and separations;
//! - `loads = −r_e·w`: the imposed loads are constant, and their work on the departure net of
//!   the equilibrium's elastic forces is that of the equilibrium reactions, reversed; plus, on a
//!   lumped model, the work `τ f^θ·v^θ` of a load `f(t)` beyond the equilibrium's (its own load
//!   from rest, and what the DOFs driven at a prescribed velocity exert on the others).
//!
//! At the equilibrium `drive` and `friction` cancel (every pair slides at `v_g`); squeal gets its
//! energy from their difference. The balance error
//! `T + E − (T₀ + E₀) − (drive + friction + normal + loads − viscous − scheme)` is zero up to
//! round-off and the accuracy of the solves: it is the audit's verdict. The four contact terms
//! add up to `τ Σ (r − r_e)·w^θ`, which the balance sums directly: `drive` and `friction` grow
//! large and opposite (μ r_n v_g per pair), and their round-off would swamp the energy of a
//! small vibration.

/// Accumulated energies and works (J) at one time.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Totals {
    pub kinetic: f64,
    pub strain: f64,
    pub viscous: f64,
    pub scheme: f64,
    pub drive: f64,
    pub friction: f64,
    pub normal: f64,
    pub loads: f64,
    pub balance_error: f64,
}

/// The running audit.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Audit {
    initial: f64,
    /// `τ Σ (r − r_e)·w^θ`, the contact terms' sum without their cancellation.
    contact_excess: f64,
    /// The work of the load beyond the equilibrium's.
    load_excess: f64,
    pub totals: Totals,
}

/// What one step contributes: the states before and after, with their products.
pub struct StepWork<'a> {
    pub tau: f64,
    pub theta: f64,
    /// The work of a load beyond the equilibrium's over the step, if there is one.
    pub load_work: Option<f64>,
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
            contact_excess: 0.0,
            load_excess: 0.0,
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
            let r = &work.r[k..k + 3];
            totals.normal += tau * r[0] * w_mid[0];
            totals.drive += tau * r[1] * speed;
            totals.friction += tau * (r[1] * (w_mid[1] - speed) + r[2] * w_mid[2]);
            totals.loads -= tau * (0..3).map(|d| work.r_e[k + d] * w_mid[d]).sum::<f64>();
            self.contact_excess += tau
                * (0..3)
                    .map(|d| (r[d] - work.r_e[k + d]) * w_mid[d])
                    .sum::<f64>();
        }
        if let Some(load_work) = work.load_work {
            totals.loads += load_work;
            self.load_excess += load_work;
        }
        totals.balance_error = totals.kinetic + totals.strain
            - self.initial
            - (self.contact_excess + self.load_excess - totals.viscous - totals.scheme);
    }
}

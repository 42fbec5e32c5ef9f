//! The sliding state of a lumped model: its equilibrium and its linearised modes, what
//! `initial: mode` starts from (as the brake's transient starts from the stability stage's
//! mode).
//!
//! # Equilibrium
//!
//! At rest on surfaces moving at `v_c ≠ 0`, every closed contact slides: `r_t = μ σ_c r_n`
//! with `σ_c = sign v_c` (the slip is `−v_c`). With `A_c = n_c + μ σ_c t_c`, the equilibrium
//! over the closed set `S` solves
//!
//! ```text
//! [ K    −A_Sᵀ ] [ q ]   [  f    ]
//! [ N_S    0   ] [ r ] = [ −g₀_S ]
//! ```
//!
//! and `S` is found by an active-set iteration: a closed contact pulling (`r_n < 0`) opens, an
//! open one that penetrates closes, one change at a time, the most violated first.
//!
//! # Linearised modes
//!
//! About it, the closed contacts hold `N_S q = 0` and push along `A_S`: `q = Z y` with `Z` a
//! basis of `ker N_S`, and the equations projected on `L`, a basis of `ker A_S` (which the
//! unknown reactions cannot reach), leave the square problem
//!
//! ```text
//! (λ² Lᵀ M Z + λ Lᵀ C' Z + Lᵀ K Z) y = 0,    C' = C + Σ_S (μ r_n,c / |v_c|) b_c b_cᵀ
//! ```
//!
//! the second term the friction-direction damping of a contact with a binormal row (Coulomb's
//! force turning with the slip). For Hoffmann's model on a belt this is Hoffmann's
//! `K = [[k11, k12 + μ k3], [k12, k22 + k3]]`.

use faer::linalg::solvers::Solve;
use faer::{Mat, MatRef, c64};

use super::model::LumpedModel;
use crate::stability::dense::quadratic_eigen;
use crate::stage::StageError;

/// Most free DOFs the dense sliding state takes.
pub const MAX_DOFS: usize = 2000;

/// The sliding equilibrium over the free DOFs.
#[derive(Debug, Clone)]
pub struct SlidingEquilibrium {
    pub q: Vec<f64>,
    /// Per contact: its normal reaction (0 when open) and whether it is closed.
    pub r_n: Vec<f64>,
    pub closed: Vec<bool>,
    /// `‖K q − f − A_Sᵀ r‖ / ‖f‖` (∞-norms; the force scale when f is zero).
    pub residual: f64,
    pub iterations: usize,
}

/// The problem's data over the free DOFs.
pub struct Sliding<'a> {
    pub model: &'a LumpedModel,
    pub free: &'a [usize],
    /// Per contact, the surface's speed it sees, and its kinetic friction coefficient.
    pub speeds: &'a [f64],
    pub mu: &'a [f64],
}

fn dense_free(A: MatRef<'_, f64>, free: &[usize]) -> Mat<f64> {
    Mat::from_fn(free.len(), free.len(), |i, j| A[(free[i], free[j])])
}

impl Sliding<'_> {
    /// `σ_c`: the sign of the friction force along t on a closed contact at rest.
    fn friction_sign(&self, c: usize) -> Result<f64, StageError> {
        let speed = self.speeds[c];
        if speed != 0.0 {
            Ok(speed.signum())
        } else if self.mu[c] == 0.0 {
            Ok(0.0)
        } else {
            Err(StageError::new(format!(
                "contact {c} closes at rest on a surface that does not move (surface_speed - tangent . prescribed velocities = 0): there is no sliding state to start a mode from; use `initial: zero` or `given`"
            )))
        }
    }

    /// The free part of a row.
    fn row(&self, row: &[f64]) -> Vec<f64> {
        self.free.iter().map(|&dof| row[dof]).collect()
    }

    /// The force direction `A_c = n_c + μ σ_c t_c` over the free DOFs.
    fn force_direction(&self, c: usize) -> Result<Vec<f64>, StageError> {
        let contact = &self.model.contacts[c];
        let sigma = self.friction_sign(c)?;
        Ok(self
            .free
            .iter()
            .map(|&dof| contact.normal[dof] + self.mu[c] * sigma * contact.tangent[dof])
            .collect())
    }

    fn check_size(&self) -> Result<(), StageError> {
        if self.free.len() > MAX_DOFS {
            return Err(StageError::new(format!(
                "initial: mode solves the sliding state densely, up to {MAX_DOFS} DOFs; the model has {}",
                self.free.len()
            )));
        }
        Ok(())
    }

    /// The sliding equilibrium under the load `f` (over the free DOFs).
    pub fn equilibrium(&self, f: &[f64]) -> Result<SlidingEquilibrium, StageError> {
        self.check_size()?;
        let model = self.model;
        let (n, m) = (self.free.len(), model.contacts.len());
        let K = dense_free(model.K.to_dense().as_ref(), self.free);
        let directions: Vec<Vec<f64>> = (0..m)
            .map(|c| self.force_direction(c))
            .collect::<Result<_, _>>()?;
        let normals: Vec<Vec<f64>> = model
            .contacts
            .iter()
            .map(|contact| self.row(&contact.normal))
            .collect();
        let gap_scale = model
            .contacts
            .iter()
            .fold(0.0_f64, |largest, contact| largest.max(contact.gap.abs()));
        let f_scale = f
            .iter()
            .fold(0.0_f64, |largest, value| largest.max(value.abs()));
        let mut closed = vec![true; m];
        let most_iterations = 4 * m + 10;
        for iteration in 1..=most_iterations {
            let set: Vec<usize> = (0..m).filter(|&c| closed[c]).collect();
            let size = n + set.len();
            let system = Mat::<f64>::from_fn(size, size, |i, j| match (i < n, j < n) {
                (true, true) => K[(i, j)],
                (true, false) => -directions[set[j - n]][i],
                (false, true) => normals[set[i - n]][j],
                (false, false) => 0.0,
            });
            let rhs = Mat::<f64>::from_fn(size, 1, |i, _| {
                if i < n {
                    f[i]
                } else {
                    -model.contacts[set[i - n]].gap
                }
            });
            let solution = system.partial_piv_lu().solve(&rhs);
            let q: Vec<f64> = (0..n).map(|i| solution[(i, 0)]).collect();
            let mut r_n = vec![0.0; m];
            for (k, &c) in set.iter().enumerate() {
                r_n[c] = solution[(n + k, 0)];
            }
            if q.iter().chain(&r_n).any(|value| !value.is_finite()) {
                return Err(StageError::new(format!(
                    "no sliding equilibrium: with contacts {set:?} closed the model is not held (K is singular on the DOFs they leave free)"
                )));
            }
            let force_scale = r_n
                .iter()
                .fold(f_scale, |largest: f64, value| largest.max(value.abs()));
            let q_scale = q
                .iter()
                .fold(gap_scale, |largest, value| largest.max(value.abs()));
            let gap = |c: usize| {
                model.contacts[c].gap + normals[c].iter().zip(&q).map(|(a, b)| a * b).sum::<f64>()
            };
            let pulling = set
                .iter()
                .copied()
                .filter(|&c| r_n[c] < -1e-12 * force_scale)
                .min_by(|&a, &b| r_n[a].total_cmp(&r_n[b]));
            let penetrating = (0..m)
                .filter(|&c| !closed[c] && gap(c) < -1e-12 * q_scale)
                .min_by(|&a, &b| gap(a).total_cmp(&gap(b)));
            match (pulling, penetrating) {
                (Some(c), _) => closed[c] = false,
                (None, Some(c)) => closed[c] = true,
                (None, None) => {
                    let mut worst = 0.0_f64;
                    for i in 0..n {
                        let mut value = f[i] - (0..n).map(|j| K[(i, j)] * q[j]).sum::<f64>();
                        for &c in &set {
                            value += directions[c][i] * r_n[c];
                        }
                        worst = worst.max(value.abs());
                    }
                    return Ok(SlidingEquilibrium {
                        q,
                        r_n,
                        closed,
                        residual: worst / force_scale.max(f64::MIN_POSITIVE),
                        iterations: iteration,
                    });
                }
            }
        }
        Err(StageError::new(format!(
            "no sliding equilibrium: the contacts' active set did not settle in {most_iterations} iterations"
        )))
    }

    /// Every eigenpair `(λ, q)` with `Im λ ≥ 0` of the linearised sliding state about
    /// `equilibrium`, `q` over the free DOFs, by decreasing `Re λ`.
    pub fn modes(
        &self,
        equilibrium: &SlidingEquilibrium,
    ) -> Result<Vec<(c64, Vec<c64>)>, StageError> {
        self.check_size()?;
        let model = self.model;
        let n = self.free.len();
        let set: Vec<usize> = (0..model.contacts.len())
            .filter(|&c| equilibrium.closed[c])
            .collect();
        let normals: Vec<Vec<f64>> = set
            .iter()
            .map(|&c| self.row(&model.contacts[c].normal))
            .collect();
        let directions: Vec<Vec<f64>> = set
            .iter()
            .map(|&c| self.force_direction(c))
            .collect::<Result<_, _>>()?;
        let Z = null_space(&normals, n, "normal rows")?;
        let L = null_space(&directions, n, "force directions n + mu t")?;
        let mut C = dense_free(model.C.to_dense().as_ref(), self.free);
        for &c in &set {
            if let Some(binormal) = &model.contacts[c].binormal {
                let b = self.row(binormal);
                let coefficient = self.mu[c] * equilibrium.r_n[c] / self.speeds[c].abs();
                for i in 0..n {
                    for j in 0..n {
                        C[(i, j)] += coefficient * b[i] * b[j];
                    }
                }
            }
        }
        let project = |A: &Mat<f64>| L.transpose() * A * &Z;
        let M = dense_free(model.M.to_dense().as_ref(), self.free);
        let K = dense_free(model.K.to_dense().as_ref(), self.free);
        let mut pairs: Vec<(c64, Vec<c64>)> = quadratic_eigen(
            project(&M).as_ref(),
            project(&C).as_ref(),
            project(&K).as_ref(),
            |lambda| lambda.im >= 0.0,
        )?
        .into_iter()
        .map(|(lambda, y)| {
            let q = (0..n)
                .map(|i| (0..y.len()).map(|k| y[k] * Z[(i, k)]).sum())
                .collect();
            (lambda, q)
        })
        .collect();
        pairs.sort_by(|a, b| b.0.re.total_cmp(&a.0.re));
        Ok(pairs)
    }
}

/// An orthonormal basis of the vectors orthogonal to `rows` (each of length `n`), as columns.
fn null_space(rows: &[Vec<f64>], n: usize, what: &str) -> Result<Mat<f64>, StageError> {
    let m = rows.len();
    if m == 0 {
        return Ok(Mat::identity(n, n));
    }
    if m >= n {
        return Err(StageError::new(format!(
            "{m} closed contacts hold all {n} free DOFs: the sliding state has no motion"
        )));
    }
    // The SVD of the n × m matrix of the rows as columns: its left singular vectors past the
    // m-th span the rows' orthogonal complement.
    let A = Mat::<f64>::from_fn(n, m, |i, k| rows[k][i]);
    let svd = A
        .svd()
        .map_err(|err| StageError::new(format!("SVD of the closed contacts' {what}: {err:?}")))?;
    let S = svd.S();
    let largest = S[0];
    if !(S[m - 1] > 1e-12 * largest) {
        return Err(StageError::new(format!(
            "the closed contacts' {what} are linearly dependent (singular values {:.3e} to {:.3e}): the sliding state's constraints are redundant",
            largest,
            S[m - 1]
        )));
    }
    let U = svd.U();
    Ok(Mat::from_fn(n, n - m, |i, k| U[(i, m + k)]))
}

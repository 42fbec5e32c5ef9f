//! The sliding-perturbation problem linearised about an equilibrium (`docs/science.md` §4).
//!
//! On every closed pair the perturbation keeps the pad on the disc, `n·δ = 0` with
//! `δ = Σ_k S_k u_k − Σ_l P_l u_l` (`u_p − u_d` node to node; [`crate::contact`]): one DOF
//! per pair, the *slave* (the free DOF of the pair's anchor pad node along the largest
//! component of n), is a combination of the others, the *masters* `q`:
//!
//! ```text
//! trial space W⁰:  u = Tᴺ q,   slave  u_s = −(Σ_{i≠s} h_i u_i) / h_s,  h the pair's normal column of Hᵀ
//! test space  W^μ: w = Tᵘ q,   same with g = n + μ t in place of n
//! ```
//!
//! (node to node: `u_s = (n·u_d − Σ_{j≠k} n_j u_{p,j}) / n_k`). A row of several pad nodes (a
//! mortar row of a quadratic face: a mid-edge node's row reads its edge's corners) may reach
//! other pairs' slave DOFs; they are replaced by their own relations, so the rows are
//! eliminated in an order where every slave a row reaches is eliminated before it (rows
//! reaching no other slave, such as every node-to-node row, first). Rows that reach each
//! other's slaves in a cycle are refused, naming a pair of the cycle.
//!
//! (conventions of [`crate::contact`]: the contact force on the pad is `r_n (n + μ t)` =
//! `Gᵀ r_n` with `G = H_n + μ H_t`, so testing with `w ∈ ker G` removes the unknown normal
//! force perturbation). The reduced quadratic eigenproblem is
//!
//! ```text
//! (λ² M̃ + λ C̃ + K̃) q = 0,   (M̃, C̃, K̃) = Tᵘᵀ (M, Ĉ, K) Tᴺ
//! Ĉ = C + μ Σ_closed (r_n / |v_g|) h_b h_bᵀ
//! ```
//!
//! where `h_b` is the pair's cross-slip row of H: linearising the friction direction
//! `(v_g − δ̇)/|v_g − δ̇|` gives the pad a force `−μ r_n (b·δ̇)/|v_g|` along b, a damping
//! (stabilising; the paper writes it with its sign r_n ≤ 0).
//!
//! Structure the solvers use: `Tᵘ = Tᴺ + Δ` with Δ nonzero on the slave rows only, so
//!
//! ```text
//! Tᵘᵀ A Tᴺ = Tᴺᵀ A Tᴺ + Σ_s δ_s (A Tᴺ)_{s,:}
//! ```
//!
//! a symmetric matrix (the μ = 0 problem) plus a correction of rank ≤ number of closed pairs.

use faer::{Mat, MatRef, c64};
use rayon::prelude::*;

use crate::artifact::ContactFrames;
use crate::artifact::Equilibrium;
use crate::artifact::{CscMatrix, Model};
use crate::contact;
use crate::stage::StageError;

/// One eliminated DOF: its full index and its value in terms of the masters.
#[derive(Debug, Clone)]
pub struct Slave {
    pub pair: usize,
    pub dof: usize,
    /// `u_s = Σ coefficient · q_master` in the trial space W⁰ (reduced indices).
    pub trial: Vec<(usize, f64)>,
    /// The same in the test space W^μ.
    pub test: Vec<(usize, f64)>,
}

/// `(M̃, C̃, K̃)` of the sliding perturbations, with the symmetric parts the solvers factorise.
pub struct SlidingSystem {
    /// Full free-DOF matrices; `C` includes the friction-direction damping.
    pub M: CscMatrix,
    pub C: CscMatrix,
    pub K: CscMatrix,
    /// Full DOF of each master (reduced) DOF.
    pub master_dofs: Vec<usize>,
    /// Reduced index of each full DOF (`None` for slaves).
    pub reduced_of: Vec<Option<usize>>,
    pub slaves: Vec<Slave>,
    /// `Tᴺᵀ (M, Ĉ, K) Tᴺ`: the μ = 0 problem, symmetric.
    pub M_sym: CscMatrix,
    pub C_sym: CscMatrix,
    pub K_sym: CscMatrix,
    /// Node → reduced DOFs (the slave omitted), for fill-reducing orderings.
    pub dof_of_node: Vec<[Option<u32>; 3]>,
    /// `‖·‖₁` of `M_sym`, `C_sym`, `K_sym`, the scales of the residual.
    pub norms: [f64; 3],
    pub mu: f64,
    /// `M` and `Ĉ` by rows on one pattern, for the shift-invert operator.
    mass_damping: PairedRows,
}

/// Which of the three matrices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    M,
    C,
    K,
}

/// One slave DOF per closed pair: the pad node's free DOF most aligned with the normal,
/// eliminated by the constraint that keeps the pair closed. Returns (pair, DOF).
fn choose_slaves(
    model: &Model,
    equilibrium: &Equilibrium,
) -> Result<Vec<(usize, usize)>, StageError> {
    let frames = &equilibrium.frames;
    let mut is_slave = vec![false; model.n_dofs()];
    let mut chosen = Vec::new();
    for (pair_idx, pair) in model.mesh.contact_pairs.iter().enumerate() {
        if !equilibrium.closed[pair_idx] {
            continue;
        }
        let normal = frames.n[pair_idx];
        let pad_dofs = model.dof_of_node[pair.pad_node() as usize];
        let axis = (0..3)
            .filter(|&axis| pad_dofs[axis].is_some())
            .max_by(|&a, &b| normal[a].abs().total_cmp(&normal[b].abs()));
        let Some(axis) = axis.filter(|&axis| normal[axis].abs() > 0.5) else {
            return Err(StageError::new(format!(
                "closed pair {pair_idx}: pad node {} is not free along its normal, so the contact cannot be kept by a perturbation",
                pair.pad_node()
            )));
        };
        let dof = pad_dofs[axis].expect("filtered on free DOFs") as usize;
        if is_slave[dof] {
            return Err(StageError::new(format!(
                "closed pair {pair_idx}: pad node {} is in two closed pairs",
                pair.pad_node()
            )));
        }
        is_slave[dof] = true;
        chosen.push((pair_idx, dof));
    }
    Ok(chosen)
}

/// The reduced index of every DOF that is not a slave, and the masters in order.
fn masters(n: usize, chosen: &[(usize, usize)]) -> (Vec<Option<usize>>, Vec<usize>) {
    let mut is_slave = vec![false; n];
    for &(_, dof) in chosen {
        is_slave[dof] = true;
    }
    let mut reduced_of = vec![None; n];
    let mut master_dofs = Vec::with_capacity(n - chosen.len());
    for dof in 0..n {
        if !is_slave[dof] {
            reduced_of[dof] = Some(master_dofs.len());
            master_dofs.push(dof);
        }
    }
    (reduced_of, master_dofs)
}

/// The slaves of the closed pairs `chosen` in terms of the masters, in the order of `chosen`.
/// A row that reaches other slaves is eliminated after them, their relations substituted; rows
/// reaching each other's slaves in a cycle are refused.
fn slaves_of(
    columns: &[Vec<(usize, f64)>],
    chosen: &[(usize, usize)],
    mu: f64,
    reduced_of: &[Option<usize>],
) -> Result<Vec<Slave>, StageError> {
    // The index in `chosen` of each slave DOF.
    let mut slave_of_dof = vec![usize::MAX; reduced_of.len()];
    for (index, &(_, dof)) in chosen.iter().enumerate() {
        slave_of_dof[dof] = index;
    }
    // The other slaves each row reaches (through its normal or tangential column).
    let reaches: Vec<Vec<usize>> = chosen
        .iter()
        .map(|&(pair, dof)| {
            let mut others: Vec<usize> = columns[3 * pair]
                .iter()
                .chain(&columns[3 * pair + 1])
                .filter(|&&(other, _)| other != dof && reduced_of[other].is_none())
                .map(|&(other, _)| slave_of_dof[other])
                .collect();
            others.sort_unstable();
            others.dedup();
            others
        })
        .collect();
    let mut slaves: Vec<Option<Slave>> = vec![None; chosen.len()];
    let mut remaining: Vec<usize> = (0..chosen.len()).collect();
    while !remaining.is_empty() {
        let before = remaining.len();
        let mut blocked = Vec::new();
        for index in remaining {
            if reaches[index].iter().all(|&other| slaves[other].is_some()) {
                let (pair, dof) = chosen[index];
                let eliminated = slave(columns, pair, dof, mu, reduced_of, &|other| {
                    slaves[slave_of_dof[other]]
                        .as_ref()
                        .expect("eliminated before")
                })?;
                slaves[index] = Some(eliminated);
            } else {
                blocked.push(index);
            }
        }
        if blocked.len() == before {
            let (pair, _) = chosen[blocked[0]];
            let other = reaches[blocked[0]]
                .iter()
                .find(|&&other| slaves[other].is_none())
                .map_or(pair, |&other| chosen[other].0);
            return Err(StageError::new(format!(
                "closed pair {pair}: its constraint row reaches the slave DOF of closed pair {other}, and the rows of such pairs reach each other's slaves in a cycle, so they cannot be eliminated one by one (a row of several pad nodes needs the anchors of its other pad nodes open or resolved first)"
            )));
        }
        remaining = blocked;
    }
    Ok(slaves
        .into_iter()
        .map(|slave| slave.expect("every row eliminated"))
        .collect())
}

/// The slave `dof` of closed pair `pair` in terms of the masters: by the normal constraint
/// (trial side) and by `n + μ t` (test side). Any other slave the row reaches is replaced by its
/// relation, from `eliminated`.
fn slave<'a>(
    columns: &[Vec<(usize, f64)>],
    pair: usize,
    dof: usize,
    mu: f64,
    reduced_of: &[Option<usize>],
    eliminated: &dyn Fn(usize) -> &'a Slave,
) -> Result<Slave, StageError> {
    // u_s from the constraint direction·δ = 0, i.e. direction·column = 0; `test` picks the
    // relation of another slave in the test space.
    let relation = |column: &[(usize, f64)], pivot: f64, test: bool| -> Vec<(usize, f64)> {
        let mut relation: Vec<(usize, f64)> = Vec::with_capacity(column.len());
        let mut add = |reduced: usize, coefficient: f64| match relation
            .iter_mut()
            .find(|(other, _)| *other == reduced)
        {
            Some(entry) => entry.1 += coefficient,
            None => relation.push((reduced, coefficient)),
        };
        for &(other, value) in column.iter().filter(|&&(other, _)| other != dof) {
            let coefficient = -value / pivot;
            match reduced_of[other] {
                Some(reduced) => add(reduced, coefficient),
                None => {
                    let other = eliminated(other);
                    let other = if test { &other.test } else { &other.trial };
                    for &(reduced, c) in other {
                        add(reduced, coefficient * c);
                    }
                }
            }
        }
        relation
    };
    let normal_column = &columns[3 * pair];
    let tangent_column = &columns[3 * pair + 1];
    // G's row: n + μ t on the same DOFs (merged).
    let mut g_column: Vec<(usize, f64)> = normal_column.clone();
    for &(other, value) in tangent_column {
        match g_column.iter_mut().find(|(dof, _)| *dof == other) {
            Some(entry) => entry.1 += mu * value,
            None => g_column.push((other, mu * value)),
        }
    }
    let pivot_of = |column: &[(usize, f64)]| {
        column
            .iter()
            .find(|&&(other, _)| other == dof)
            .map_or(0.0, |&(_, value)| value)
    };
    let (normal_pivot, g_pivot) = (pivot_of(normal_column), pivot_of(&g_column));
    if !(g_pivot.abs() > 1e-3 * normal_pivot.abs()) {
        return Err(StageError::new(format!(
            "closed pair {pair}: (n + mu t) has no component along the eliminated DOF (mu = {mu})"
        )));
    }
    Ok(Slave {
        pair,
        dof,
        trial: relation(normal_column, normal_pivot, false),
        test: relation(&g_column, g_pivot, true),
    })
}

/// `Ĉ = C + μ Σ (r_n / V) h_b h_bᵀ`: the friction direction's linearised damping.
fn friction_damped(
    model: &Model,
    equilibrium: &Equilibrium,
    columns: &[Vec<(usize, f64)>],
) -> CscMatrix {
    let n = model.n_dofs();
    let mut triplets: Vec<(usize, usize, f64)> = model.C.triplets().collect();
    for (pair_idx, closed) in equilibrium.closed.iter().enumerate() {
        if !closed {
            continue;
        }
        let coefficient =
            equilibrium.mu * equilibrium.r_n[pair_idx] / equilibrium.frames.sliding_speed[pair_idx];
        let binormal = &columns[3 * pair_idx + 2];
        for &(row, a) in binormal {
            for &(col, b) in binormal {
                triplets.push((row, col, coefficient * a * b));
            }
        }
    }
    CscMatrix::from_triplets(n, n, triplets)
}

impl SlidingSystem {
    /// The sliding perturbations of `model` about `equilibrium`; `friction_damping` adds the
    /// linearised friction-direction term to C.
    pub fn new(
        model: &Model,
        equilibrium: &Equilibrium,
        friction_damping: bool,
    ) -> Result<SlidingSystem, StageError> {
        let n = model.n_dofs();
        equilibrium.check_belongs_to(model)?;
        let mu = equilibrium.mu;
        let frames: &ContactFrames = &equilibrium.frames;
        let columns = contact::h_columns(model, frames);
        let chosen = choose_slaves(model, equilibrium)?;
        let (reduced_of, master_dofs) = masters(n, &chosen);
        let slaves = slaves_of(&columns, &chosen, mu, &reduced_of)?;
        let C = if friction_damping && mu > 0.0 {
            friction_damped(model, equilibrium, &columns)
        } else {
            model.C.clone()
        };

        if n > u32::MAX as usize {
            return Err(StageError::new(format!(
                "{n} DOFs: the sliding problem indexes at most {} DOFs",
                u32::MAX
            )));
        }
        let mass_damping = PairedRows::new(&model.M, &C);
        let mut system = SlidingSystem {
            M: model.M.clone(),
            C,
            K: model.K.clone(),
            master_dofs,
            reduced_of,
            slaves,
            M_sym: CscMatrix::default(),
            C_sym: CscMatrix::default(),
            K_sym: CscMatrix::default(),
            dof_of_node: Vec::new(),
            norms: [0.0; 3],
            mu,
            mass_damping,
        };
        system.set_symmetric_parts();
        system.dof_of_node = model
            .dof_of_node
            .iter()
            .map(|dofs| {
                dofs.map(|dof| {
                    dof.and_then(|dof| system.reduced_of[dof as usize].map(|r| r as u32))
                })
            })
            .collect();
        Ok(system)
    }

    /// The transposed problem `(λ² M̃ᵀ + λ C̃ᵀ + K̃ᵀ) y = 0`: trial and test spaces swapped
    /// (`M`, `Ĉ`, `K` are symmetric, so `Q̃ᵀ = Tᴺᵀ Q Tᵘ`). Its eigenvectors are the left
    /// eigenvectors of this one, `yᵀ Q̃(λ) = 0`.
    pub fn transposed(&self) -> SlidingSystem {
        let mut system = SlidingSystem {
            M: self.M.clone(),
            C: self.C.clone(),
            K: self.K.clone(),
            master_dofs: self.master_dofs.clone(),
            reduced_of: self.reduced_of.clone(),
            slaves: self
                .slaves
                .iter()
                .map(|slave| Slave {
                    trial: slave.test.clone(),
                    test: slave.trial.clone(),
                    ..slave.clone()
                })
                .collect(),
            M_sym: CscMatrix::default(),
            C_sym: CscMatrix::default(),
            K_sym: CscMatrix::default(),
            dof_of_node: self.dof_of_node.clone(),
            norms: [0.0; 3],
            mu: self.mu,
            mass_damping: PairedRows::new(&self.M, &self.C),
        };
        system.set_symmetric_parts();
        system
    }

    /// `Tᴺᵀ (M, Ĉ, K) Tᴺ` of the trial space, and their norms.
    fn set_symmetric_parts(&mut self) {
        self.M_sym = self.congruence(&self.M);
        self.C_sym = self.congruence(&self.C);
        self.K_sym = self.congruence(&self.K);
        self.norms = [
            self.M_sym.norm_1(),
            self.C_sym.norm_1(),
            self.K_sym.norm_1(),
        ];
    }

    /// `yᵀ Q̃′(λ) x = (Tᵘ y)ᵀ (2λ M + Ĉ) (Tᴺ x)`, with `y` a left eigenvector: the
    /// denominator of the condition number.
    pub fn derivative_form(&self, lambda: c64, y: &[c64], x: &[c64]) -> c64 {
        let u = self.expand(x);
        let w = self.transposed_expand(y);
        let (Mu, Cu) = (mul_complex(&self.M, &u), mul_complex(&self.C, &u));
        w.iter()
            .zip(Mu.iter().zip(&Cu))
            .map(|(w, (m, c))| w * (2.0 * lambda * m + c))
            .sum()
    }

    /// `Tᵘ y`: a reduced vector expanded in the test space.
    fn transposed_expand(&self, y: &[c64]) -> Vec<c64> {
        let mut w = vec![c64::new(0.0, 0.0); self.full_dim()];
        for (reduced, &dof) in self.master_dofs.iter().enumerate() {
            w[dof] = y[reduced];
        }
        for slave in &self.slaves {
            w[slave.dof] = slave
                .test
                .iter()
                .map(|&(reduced, coefficient)| y[reduced] * coefficient)
                .sum();
        }
        w
    }

    /// Number of reduced (master) DOFs.
    pub fn dim(&self) -> usize {
        self.master_dofs.len()
    }

    /// Number of full DOFs.
    pub fn full_dim(&self) -> usize {
        self.reduced_of.len()
    }

    pub fn full(&self, part: Part) -> &CscMatrix {
        match part {
            Part::M => &self.M,
            Part::C => &self.C,
            Part::K => &self.K,
        }
    }

    pub fn symmetric(&self, part: Part) -> &CscMatrix {
        match part {
            Part::M => &self.M_sym,
            Part::C => &self.C_sym,
            Part::K => &self.K_sym,
        }
    }

    /// Row `dof` of Tᴺ (trial) or Tᵘ (test) as (reduced index, coefficient).
    fn row(&self, dof: usize, test: bool) -> Vec<(usize, f64)> {
        match self.reduced_of[dof] {
            Some(reduced) => vec![(reduced, 1.0)],
            None => {
                let slave = self
                    .slaves
                    .iter()
                    .find(|slave| slave.dof == dof)
                    .expect("a DOF is a master or a slave");
                if test {
                    slave.test.clone()
                } else {
                    slave.trial.clone()
                }
            }
        }
    }

    /// `Tᴺᵀ A Tᴺ` for a full symmetric `A`.
    fn congruence(&self, A: &CscMatrix) -> CscMatrix {
        self.project(A, false)
    }

    /// `Tᵘᵀ A Tᴺ` (`test`) or `Tᴺᵀ A Tᴺ`, sparse.
    fn project(&self, A: &CscMatrix, test: bool) -> CscMatrix {
        let m = self.dim();
        let rows = |test: bool| -> Vec<Vec<(usize, f64)>> {
            (0..self.full_dim())
                .map(|dof| self.row(dof, test))
                .collect()
        };
        let (test_rows, trial_rows) = (rows(test), rows(false));
        let mut triplets = Vec::with_capacity(A.values.len());
        for (row, col, value) in A.triplets() {
            for &(a, t_a) in &test_rows[row] {
                for &(b, t_b) in &trial_rows[col] {
                    triplets.push((a, b, value * t_a * t_b));
                }
            }
        }
        CscMatrix::from_triplets(m, m, triplets)
    }

    /// `M̃`, `C̃` or `K̃` as a sparse matrix (for export).
    pub fn reduced_matrix(&self, part: Part) -> CscMatrix {
        self.project(self.full(part), true)
    }

    /// `u = Tᴺ q`: the full displacement of a reduced vector.
    pub fn expand(&self, q: &[c64]) -> Vec<c64> {
        self.expand_rows(&[MatRef::from_column_major_slice(q, q.len(), 1)])
    }

    /// `Tᵘᵀ y` (test) or `Tᴺᵀ y` of a full vector.
    pub fn restrict(&self, y: &[c64], test: bool) -> Vec<c64> {
        self.restrict_rows(y, 1, test)
            .col(0)
            .iter()
            .copied()
            .collect()
    }

    /// `Tᵘᵀ A Tᴺ X` for `A` = M, Ĉ or K and the columns of `X`.
    pub fn apply_block(&self, part: Part, X: MatRef<'_, c64>) -> Mat<c64> {
        let width = X.ncols();
        let source = self.expand_rows(&[X]);
        let mut Y = vec![c64::new(0.0, 0.0); self.full_dim() * width];
        if width > 0 {
            let A = self.full(part);
            Y.par_chunks_mut(GATHER_ROWS * width)
                .enumerate()
                .for_each(|(chunk, rows)| {
                    gather_rows(A, &source, width, chunk * GATHER_ROWS, rows)
                });
        }
        self.restrict_rows(&Y, width, true)
    }

    /// `Tᵘᵀ (M Tᴺ X + Ĉ Tᴺ Y)` for blocks `X`, `Y` of one width: the shift-invert operator's
    /// product, by `PairedRows`.
    pub fn apply_mass_damping(&self, X: MatRef<'_, c64>, Y: MatRef<'_, c64>) -> Mat<c64> {
        let width = X.ncols();
        assert_eq!(Y.ncols(), width, "blocks of one width");
        let source = self.expand_rows(&[X, Y]);
        let Z = self.mass_damping.apply(&source, width);
        self.restrict_rows(&Z, width, true)
    }

    /// `Tᴺ X` for the blocks `X` side by side, row-major: entry (dof, j) of the blocks'
    /// columns in turn at `dof · width + j`, `width` their total.
    fn expand_rows(&self, blocks: &[MatRef<'_, c64>]) -> Vec<c64> {
        let width: usize = blocks.iter().map(|X| X.ncols()).sum();
        let mut u = vec![c64::new(0.0, 0.0); self.full_dim() * width];
        for (reduced, &dof) in self.master_dofs.iter().enumerate() {
            let row = &mut u[dof * width..(dof + 1) * width];
            let mut j = 0;
            for X in blocks {
                for col in 0..X.ncols() {
                    row[j] = X[(reduced, col)];
                    j += 1;
                }
            }
        }
        for slave in &self.slaves {
            for &(reduced, coefficient) in &slave.trial {
                let row = &mut u[slave.dof * width..(slave.dof + 1) * width];
                let mut j = 0;
                for X in blocks {
                    for col in 0..X.ncols() {
                        row[j] += X[(reduced, col)] * coefficient;
                        j += 1;
                    }
                }
            }
        }
        u
    }

    /// `Tᵘᵀ Y` (test) or `Tᴺᵀ Y` for a row-major block `Y` over the full DOFs.
    fn restrict_rows(&self, Y: &[c64], width: usize, test: bool) -> Mat<c64> {
        let mut Z = Mat::<c64>::from_fn(self.dim(), width, |reduced, j| {
            Y[self.master_dofs[reduced] * width + j]
        });
        for slave in &self.slaves {
            let relation = if test { &slave.test } else { &slave.trial };
            for &(reduced, coefficient) in relation {
                for j in 0..width {
                    Z[(reduced, j)] += Y[slave.dof * width + j] * coefficient;
                }
            }
        }
        Z
    }

    /// The residual figure of an eigenpair:
    /// `‖(λ² M̃ + λ C̃ + K̃) q‖ / ((|λ|² ‖M̃‖ + |λ| ‖C̃‖ + ‖K̃‖) ‖q‖)`.
    pub fn residual(&self, lambda: c64, q: &[c64]) -> f64 {
        self.residuals(&[lambda], MatRef::from_column_major_slice(q, q.len(), 1))[0]
    }

    /// [`Self::residual`] of the eigenpairs `(lambdas[j], Q[:, j])`. The vectors go through the
    /// matrices in blocks, each matrix entry read once per block: the products are bound by
    /// memory traffic, not arithmetic.
    pub fn residuals(&self, lambdas: &[c64], Q: MatRef<'_, c64>) -> Vec<f64> {
        let n = self.full_dim();
        let blocks: Vec<Vec<f64>> = (0..lambdas.len())
            .step_by(GROUP_WIDTH)
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|first| {
                let width = GROUP_WIDTH.min(lambdas.len() - first);
                let u = self.expand_rows(&[Q.subcols(first, width)]);
                let q_norms: Vec<f64> = (0..width).map(|j| Q.col(first + j).norm_l2()).collect();
                let [Mu, Cu, Ku] =
                    [Part::M, Part::C, Part::K].map(|part| mul_rows(self.full(part), &u, width));
                (0..width)
                    .map(|j| {
                        let lambda = lambdas[first + j];
                        let y: Vec<c64> = (0..n)
                            .map(|dof| {
                                let e = dof * width + j;
                                lambda * lambda * Mu[e] + lambda * Cu[e] + Ku[e]
                            })
                            .collect();
                        let r = self.restrict(&y, true);
                        let scale = lambda.norm_sqr() * self.norms[0]
                            + lambda.norm() * self.norms[1]
                            + self.norms[2];
                        norm(&r) / (scale * q_norms[j]).max(f64::MIN_POSITIVE)
                    })
                    .collect()
            })
            .collect();
        blocks.concat()
    }
}

/// Most vectors put through a matrix together: wide enough that the matrix is read a few
/// times per block, narrow enough that a group's rows stay in cache.
const GROUP_WIDTH: usize = 16;

/// Rows of a product per task.
const GATHER_ROWS: usize = 1024;

/// `Y = A X` for a real sparse `A` and complex vectors `X` stored row-major, `width` per row.
fn mul_rows(A: &CscMatrix, X: &[c64], width: usize) -> Vec<c64> {
    let mut Y = vec![c64::new(0.0, 0.0); A.n_rows * width];
    gather_rows(A, X, width, 0, &mut Y);
    Y
}

/// Two symmetric matrices `A`, `B` (M and Ĉ) by rows on the union of their patterns, so that
/// `A X + B Y` reads the pattern once. Consecutive rows with the same pattern (a node's three
/// DOFs) form a group that stores its column indices (`u32`) once and, per entry, both values
/// of each of its rows: each row of `X` and `Y` the group points to is read once for all of
/// its rows.
struct PairedRows {
    /// Group g: rows `row_start[g]..row_start[g + 1]`, pattern `cols[col_start[g]..col_start[g
    /// + 1]]`, values from `value_start[g]`, entry by entry, row by row within each entry.
    row_start: Vec<usize>,
    col_start: Vec<usize>,
    value_start: Vec<usize>,
    cols: Vec<u32>,
    values: Vec<[f64; 2]>,
    /// Consecutive groups of about [`GATHER_ROWS`] rows, one task each.
    tasks: Vec<std::ops::Range<usize>>,
}

/// Most rows in a group of [`PairedRows`].
const GROUP_ROWS: usize = 8;

impl PairedRows {
    /// `A` and `B` square, symmetric (row r is column r), of the same size, with fewer than
    /// 2³² rows.
    fn new(A: &CscMatrix, B: &CscMatrix) -> PairedRows {
        let n = A.n_cols;
        assert_eq!(
            (B.n_rows, B.n_cols, A.n_rows),
            (n, n, n),
            "square, of one size"
        );
        // Each row on the union pattern, sorted by column.
        let mut row_ptr = vec![0];
        let mut entries: Vec<(u32, [f64; 2])> = Vec::new();
        // Where column c was stored in the row being built (stale below the row's start).
        let mut slot = vec![usize::MAX; n];
        for r in 0..n {
            let start = entries.len();
            for (which, matrix) in [A, B].into_iter().enumerate() {
                for entry in matrix.col_ptr[r]..matrix.col_ptr[r + 1] {
                    let c = matrix.row_idx[entry];
                    if slot[c] == usize::MAX || slot[c] < start {
                        slot[c] = entries.len();
                        entries.push((c as u32, [0.0; 2]));
                    }
                    entries[slot[c]].1[which] += matrix.values[entry];
                }
            }
            entries[start..].sort_unstable_by_key(|&(c, _)| c);
            row_ptr.push(entries.len());
        }
        let row = |r: usize| &entries[row_ptr[r]..row_ptr[r + 1]];
        let same_pattern =
            |r: usize, s: usize| row(r).iter().map(|e| e.0).eq(row(s).iter().map(|e| e.0));
        let mut pairs = PairedRows {
            row_start: vec![0],
            col_start: vec![0],
            value_start: vec![0],
            cols: Vec::new(),
            values: Vec::new(),
            tasks: Vec::new(),
        };
        let mut r = 0;
        while r < n {
            let mut end = r + 1;
            while end < n && end - r < GROUP_ROWS && same_pattern(r, end) {
                end += 1;
            }
            pairs.cols.extend(row(r).iter().map(|e| e.0));
            for e in 0..row(r).len() {
                pairs.values.extend((r..end).map(|s| row(s)[e].1));
            }
            pairs.row_start.push(end);
            pairs.col_start.push(pairs.cols.len());
            pairs.value_start.push(pairs.values.len());
            r = end;
        }
        let groups = pairs.row_start.len() - 1;
        let mut first = 0;
        for g in 0..groups {
            if pairs.row_start[g + 1] - pairs.row_start[first] >= GATHER_ROWS || g + 1 == groups {
                pairs.tasks.push(first..g + 1);
                first = g + 1;
            }
        }
        pairs
    }

    /// `A X + B Y` for `source` holding the rows of `X` and `Y` side by side (`2 · width` per
    /// row), row-major, the tasks shared among the threads.
    fn apply(&self, source: &[c64], width: usize) -> Vec<c64> {
        let n = self.row_start.last().copied().unwrap_or(0);
        let mut Z = vec![c64::new(0.0, 0.0); n * width];
        let mut parts = Vec::with_capacity(self.tasks.len());
        let mut rest = Z.as_mut_slice();
        for task in &self.tasks {
            let rows = self.row_start[task.end] - self.row_start[task.start];
            let (part, tail) = rest.split_at_mut(rows * width);
            parts.push((task.clone(), part));
            rest = tail;
        }
        parts
            .into_par_iter()
            .for_each(|(groups, out)| self.gather(source, width, groups, out));
        Z
    }

    /// The rows of `groups` into `out` (their rows, row-major).
    fn gather(
        &self,
        source: &[c64],
        width: usize,
        groups: std::ops::Range<usize>,
        out: &mut [c64],
    ) {
        let first_row = self.row_start[groups.start];
        for g in groups {
            let rows = self.row_start[g + 1] - self.row_start[g];
            let at = (self.row_start[g] - first_row) * width;
            let out = &mut out[at..at + rows * width];
            let values = &self.values[self.value_start[g]..self.value_start[g + 1]];
            let cols = &self.cols[self.col_start[g]..self.col_start[g + 1]];
            for (&col, values) in cols.iter().zip(values.chunks_exact(rows)) {
                let start = 2 * width * col as usize;
                let (x, y) = source[start..start + 2 * width].split_at(width);
                for (row, &[a, b]) in out.chunks_exact_mut(width).zip(values) {
                    for ((z, x), y) in row.iter_mut().zip(x).zip(y) {
                        *z += x * a + y * b;
                    }
                }
            }
        }
    }
}

/// Rows `first..` (as many as `Y` holds, row-major, `width` per row) of `A U`: row r of A is
/// column r, since M, Ĉ and K are symmetric, so each row of the result is a sum of rows of U
/// read where its entries point. Gathering reads scattered rows but writes each result row
/// once, and the rows can be shared among threads; scattering column by column reads and
/// writes scattered rows of the result.
fn gather_rows(A: &CscMatrix, U: &[c64], width: usize, first: usize, Y: &mut [c64]) {
    for (offset, row) in Y.chunks_exact_mut(width).enumerate() {
        let r = first + offset;
        for entry in A.col_ptr[r]..A.col_ptr[r + 1] {
            let (source, a) = (A.row_idx[entry], A.values[entry]);
            for (y, u) in row.iter_mut().zip(&U[source * width..(source + 1) * width]) {
                *y += u * a;
            }
        }
    }
}

/// `y = A x` for a real sparse `A` and a complex `x`.
pub fn mul_complex(A: &CscMatrix, x: &[c64]) -> Vec<c64> {
    let mut y = vec![c64::new(0.0, 0.0); A.n_rows];
    for (col, &x_col) in x.iter().enumerate().take(A.n_cols) {
        if x_col == c64::new(0.0, 0.0) {
            continue;
        }
        for entry in A.col_ptr[col]..A.col_ptr[col + 1] {
            y[A.row_idx[entry]] += x_col * A.values[entry];
        }
    }
    y
}

pub fn norm(x: &[c64]) -> f64 {
    x.iter().map(|value| value.norm_sqr()).sum::<f64>().sqrt()
}

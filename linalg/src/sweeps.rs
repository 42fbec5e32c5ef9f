//! The two triangular sweeps of a supernodal Cholesky factor on one vector, `L y = b` and
//! `Lᵀ x = y`, with independent subtrees of the elimination tree swept in parallel.
//!
//! A supernode's columns update only rows of its ancestors in the elimination tree, so the
//! subtrees below a set of supernodes closed under taking ancestors (the *top*) are
//! independent of one another. The forward sweep runs each such subtree as one task on a
//! copy of its own entries, its updates of the top's rows summed in a buffer of its own and
//! subtracted afterwards in task order; then it sweeps the top alone. The backward sweep runs
//! the top first, then the subtrees, each reading the top's values.
//!
//! Within a supernode (a dense block of columns and the rows below them, column-major) each
//! column is read once, contiguously from its diagonal down: an `axpy` into the supernode's
//! rows in the forward sweep, a `dot` with them in the backward one, on the widest vector unit
//! ([`crate::kernels`]). faer's triangular solve and product on one vector read the default
//! brake's factor at two thirds of that rate.
//!
//! A sweep is bound by reading the factor from memory, once per sweep: two cores read it at
//! nearly twice the rate of one. The partition depends on the tree alone, never on the
//! thread count, and so does every sum: the result is bit-identical on any number of threads
//! (it differs from a sequential sweep in the last bits, by the order of the top's sums).

use faer::MatRef;
use faer::sparse::linalg::cholesky::supernodal::SupernodalLltRef;
use rayon::prelude::*;

use crate::kernels::{axpy, dot};

/// Subtrees swept as separate tasks, at most. Fixed, so that the partition and the sums do not
/// depend on the thread count; enough to balance a few cores.
const TASKS: usize = 8;

/// Factors lighter than this (in entries) are swept as one sequential top: waking the tasks
/// would cost more than the sweep (a few microseconds against a reduced or lumped model's
/// sub-microsecond sweep, a million times in a long run).
const PARALLEL_WEIGHT: usize = 100_000;

/// One task: a whole subtree, its supernodes (ascending) and their columns, in that order.
#[derive(Debug, Clone)]
struct Task {
    supernodes: Vec<usize>,
    columns: Vec<usize>,
}

/// Where a row lives: a task's copy, or the top.
const TOP: u32 = u32::MAX;

/// The partition of a factor's supernodes into parallel subtrees and the sequential top.
#[derive(Debug, Clone, Default)]
pub struct SubtreeSweeps {
    tasks: Vec<Task>,
    /// Supernodes swept alone, ascending.
    top: Vec<usize>,
    /// Rows of the top supernodes, ascending.
    top_rows: Vec<usize>,
    /// Per row: the task whose copy holds it, or [`TOP`]; and its position in that copy, or
    /// in `top_rows`.
    owner: Vec<u32>,
    slot: Vec<u32>,
}

/// One supernode's block: its first column, its diagonal block, the block below it and the
/// rows of that block.
struct Block<'a> {
    start: usize,
    /// The diagonal block over the block below it, column-major.
    columns: MatRef<'a, f64>,
    rows: &'a [usize],
}

fn block<'a>(L: SupernodalLltRef<'a, usize, f64>, s: usize) -> Block<'a> {
    let supernode = L.supernode(s);
    let values = supernode.val();
    Block {
        start: supernode.start(),
        columns: values,
        rows: supernode.pattern(),
    }
}

impl SubtreeSweeps {
    /// Splits the elimination forest of `L` (`n` unknowns): starting from its roots, the
    /// heaviest subtree (in factor entries) is replaced by its children, its root joining the
    /// top, until none outweighs half a task's share or the heaviest is a single supernode;
    /// the subtrees are then packed into `TASKS` tasks.
    pub fn new(L: SupernodalLltRef<'_, usize, f64>, n: usize) -> SubtreeSweeps {
        let symbolic = L.symbolic();
        let n_supernodes = symbolic.n_supernodes();
        let (begin, end) = (symbolic.supernode_begin(), symbolic.supernode_end());
        let mut supernode_of_column = vec![0usize; n];
        for s in 0..n_supernodes {
            supernode_of_column[begin[s]..end[s]].fill(s);
        }
        let mut children = vec![Vec::new(); n_supernodes];
        let mut roots = Vec::new();
        let mut weight = vec![0usize; n_supernodes];
        // A supernode updates only later ones (its ancestors): one ascending pass sums
        // subtrees.
        for s in 0..n_supernodes {
            let b = block(L, s);
            weight[s] += b.columns.ncols() * b.columns.nrows();
            match b.rows.first() {
                Some(&row) => {
                    let parent = supernode_of_column[row];
                    children[parent].push(s);
                    weight[parent] += weight[s];
                }
                None => roots.push(s),
            }
        }
        // Split the heaviest subtree while it outweighs a share of the whole, then pack the
        // subtrees into TASKS bins, heaviest first into the lightest bin.
        let total: usize = roots.iter().map(|&root| weight[root]).sum();
        let mut frontier = roots;
        let mut top = Vec::new();
        let heaviest_of = |frontier: &[usize]| {
            frontier
                .iter()
                .copied()
                .enumerate()
                .max_by_key(|&(_, s)| (weight[s], std::cmp::Reverse(s)))
        };
        if total < PARALLEL_WEIGHT {
            // Every supernode in the top, in elimination order: no tasks.
            frontier.clear();
            top.extend(0..n_supernodes);
        }
        while let Some((position, heaviest)) = heaviest_of(&frontier) {
            if weight[heaviest] * 2 * TASKS <= total || children[heaviest].is_empty() {
                break;
            }
            frontier.swap_remove(position);
            frontier.extend_from_slice(&children[heaviest]);
            top.push(heaviest);
        }
        frontier.sort_unstable_by_key(|&s| (std::cmp::Reverse(weight[s]), s));
        let mut bins: Vec<(usize, Vec<usize>)> = vec![(0, Vec::new()); TASKS.min(frontier.len())];
        for &root in &frontier {
            let lightest = (0..bins.len())
                .min_by_key(|&bin| (bins[bin].0, bin))
                .expect("a bin");
            bins[lightest].0 += weight[root];
            bins[lightest].1.push(root);
        }
        top.sort_unstable();
        let mut owner = vec![TOP; n];
        let mut slot = vec![0u32; n];
        let tasks: Vec<Task> = bins
            .into_iter()
            .enumerate()
            .map(|(task, (_, roots))| {
                let mut supernodes = roots;
                let mut next = 0;
                while next < supernodes.len() {
                    supernodes.extend_from_slice(&children[supernodes[next]]);
                    next += 1;
                }
                supernodes.sort_unstable();
                let columns: Vec<usize> =
                    supernodes.iter().flat_map(|&s| begin[s]..end[s]).collect();
                for (position, &column) in columns.iter().enumerate() {
                    owner[column] = task as u32;
                    slot[column] = position as u32;
                }
                Task {
                    supernodes,
                    columns,
                }
            })
            .collect();
        let top_rows: Vec<usize> = top.iter().flat_map(|&s| begin[s]..end[s]).collect();
        for (position, &row) in top_rows.iter().enumerate() {
            slot[row] = position as u32;
        }
        SubtreeSweeps {
            tasks,
            top,
            top_rows,
            owner,
            slot,
        }
    }

    /// Subtrees swept in parallel.
    pub fn n_tasks(&self) -> usize {
        self.tasks.len()
    }

    /// `y = L⁻¹ b` in place (`x` in elimination order).
    pub fn forward(&self, L: SupernodalLltRef<'_, usize, f64>, x: &mut [f64]) {
        let n_top = self.top_rows.len();
        if self.tasks.is_empty() {
            return self.forward_top(L, x);
        }
        let swept: Vec<(Vec<f64>, Vec<f64>)> = self
            .tasks
            .par_iter()
            .enumerate()
            .map(|(task_id, task)| {
                let mut local: Vec<f64> = task.columns.iter().map(|&column| x[column]).collect();
                let mut top_updates = vec![0.0; n_top];
                let mut product = Vec::new();
                for &s in &task.supernodes {
                    let b = block(L, s);
                    let offset = self.slot[b.start] as usize;
                    solve_diagonal(&b, &mut local[offset..], &mut product);
                    for (&row, &value) in b.rows.iter().zip(&product) {
                        let slot = self.slot[row] as usize;
                        if self.owner[row] == task_id as u32 {
                            local[slot] -= value;
                        } else {
                            top_updates[slot] += value;
                        }
                    }
                }
                (local, top_updates)
            })
            .collect();
        for (task, (local, top_updates)) in self.tasks.iter().zip(&swept) {
            for (&column, &value) in task.columns.iter().zip(local) {
                x[column] = value;
            }
            for (&row, &value) in self.top_rows.iter().zip(top_updates) {
                x[row] -= value;
            }
        }
        self.forward_top(L, x);
    }

    /// The top's part of the forward sweep, sequential, after the tasks'.
    fn forward_top(&self, L: SupernodalLltRef<'_, usize, f64>, x: &mut [f64]) {
        let mut product = Vec::new();
        for &s in &self.top {
            let b = block(L, s);
            solve_diagonal(&b, &mut x[b.start..], &mut product);
            for (&row, &value) in b.rows.iter().zip(&product) {
                x[row] -= value;
            }
        }
    }

    /// `x = L⁻ᵀ y` in place (`x` in elimination order).
    pub fn backward(&self, L: SupernodalLltRef<'_, usize, f64>, x: &mut [f64]) {
        let mut z = Vec::new();
        for &s in self.top.iter().rev() {
            let b = block(L, s);
            z.clear();
            z.resize(b.columns.ncols(), 0.0);
            z.extend(b.rows.iter().map(|&row| x[row]));
            solve_diagonal_transposed(&b, &mut x[b.start..], &mut z);
        }
        if self.tasks.is_empty() {
            return;
        }
        let shared: &[f64] = x;
        let swept: Vec<Vec<f64>> = self
            .tasks
            .par_iter()
            .enumerate()
            .map(|(task_id, task)| {
                let mut local: Vec<f64> =
                    task.columns.iter().map(|&column| shared[column]).collect();
                let mut z = Vec::new();
                for &s in task.supernodes.iter().rev() {
                    let b = block(L, s);
                    z.clear();
                    z.resize(b.columns.ncols(), 0.0);
                    z.extend(b.rows.iter().map(|&row| {
                        if self.owner[row] == task_id as u32 {
                            local[self.slot[row] as usize]
                        } else {
                            shared[row]
                        }
                    }));
                    let offset = self.slot[b.start] as usize;
                    solve_diagonal_transposed(&b, &mut local[offset..], &mut z);
                }
                local
            })
            .collect();
        for (task, local) in self.tasks.iter().zip(&swept) {
            for (&column, &value) in task.columns.iter().zip(local) {
                x[column] = value;
            }
        }
    }
}

/// Column `j` of a supernode, from its diagonal entry down (contiguous: column-major).
fn column_from_diagonal<'a>(b: &Block<'a>, j: usize) -> &'a [f64] {
    let column = b
        .columns
        .col(j)
        .try_as_col_major()
        .expect("a supernode is stored column-major")
        .as_slice();
    &column[j..]
}

/// `x_s = L_ss⁻¹ x_s` on the supernode's leading entries of `x`, and `product = L_below x_s`:
/// column after column, each read once from its diagonal down (`axpy` on the widest vector
/// unit) into `[x_s; −product]`.
fn solve_diagonal(b: &Block<'_>, x: &mut [f64], product: &mut Vec<f64>) {
    let size = b.columns.ncols();
    product.clear();
    product.extend_from_slice(&x[..size]);
    product.resize(size + b.rows.len(), 0.0);
    for j in 0..size {
        let column = column_from_diagonal(b, j);
        let x_j = product[j] / column[0];
        product[j] = x_j;
        axpy(-x_j, &column[1..], &mut product[j + 1..]);
    }
    x[..size].copy_from_slice(&product[..size]);
    product.drain(..size);
    for value in product.iter_mut() {
        *value = -*value;
    }
}

/// `x_s = L_ss⁻ᵀ (x_s − L_belowᵀ below)` on the supernode's leading entries of `x`, `z` holding
/// room for `x_s` and then `below`: from the last column back, each read once from its diagonal
/// down (`dot` on the widest vector unit) against `[x_s; below]`.
fn solve_diagonal_transposed(b: &Block<'_>, x: &mut [f64], z: &mut [f64]) {
    let size = b.columns.ncols();
    z[..size].copy_from_slice(&x[..size]);
    for j in (0..size).rev() {
        let column = column_from_diagonal(b, j);
        z[j] = (z[j] - dot(&column[1..], &z[j + 1..])) / column[0];
    }
    x[..size].copy_from_slice(&z[..size]);
}

//! The LBLᵀ factor of a symmetric indefinite matrix (faer's, Bunch–Kaufman pivoting inside
//! supernodes) and its solves for a few right-hand sides at a time.
//!
//! The factor `P A Pᵀ = L B Lᵀ` (L unit lower triangular, B block diagonal with 1×1 and 2×2
//! blocks, P the fill-reducing ordering composed with the pivoting inside supernodes) is
//! applied as faer applies it, supernode by supernode:
//!
//! ```text
//! forward   x_top ← L_top⁻¹ x_top,        x[pattern] −= L_bot x_top
//! diagonal  x ← B⁻¹ x
//! backward  x_top −= L_botᵀ x[pattern],   x_top ← L_top⁻ᵀ x_top
//! ```
//!
//! The arithmetic is the same; the kernels and the parallelism are not. faer runs each
//! supernode's products through its general matrix kernels, built for wide right-hand sides,
//! and a Krylov block has eight. Here the right-hand sides are stored by rows (`x[i][j]`), so
//! each entry of L is read once per sweep and multiplies eight contiguous values, four columns
//! of L at a time, with AVX2 and FMA chosen at run time. The threads share the supernodal tree
//! ([`TreeSplit`]): each sweeps whole subtrees, with all eight columns, on a private copy of x,
//! and one thread sweeps the supernodes above them. Reading L is not the limit: the time goes
//! to the scattered rows of x (timings: `docs/PERFORMANCE.md`).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::perm::PermRef;
use faer::reborrow::ReborrowMut;
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::cholesky::IntranodeLbltRef;
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::sparse::linalg::cholesky::{SymbolicCholesky, SymbolicCholeskyRaw};
use faer::{Conj, MatMut, Par, Side};
use rayon::prelude::*;

/// The numeric LBLᵀ factor of a symmetric matrix, on a symbolic analysis kept by the caller.
pub struct Lblt {
    values: Vec<f64>,
    subdiag: Vec<f64>,
    /// The pivoting permutation inside supernodes: forward and inverse.
    pivot_forward: Vec<usize>,
    pivot_inverse: Vec<usize>,
    /// The threads of `par`, and the tree shared among them when the row-major kernels apply.
    threads: usize,
    split: Option<TreeSplit>,
    /// The supernodal elimination tree, for the forward sweep of sparse right-hand sides.
    tree: Option<SupernodeTree>,
}

impl Lblt {
    /// Factorises `A` (lower triangle) with Bunch–Kaufman pivoting inside supernodes; solves
    /// will share the supernodal tree among the threads of `par`.
    pub fn factorize(
        symbolic: &SymbolicCholesky<usize>,
        A: SparseColMatRef<'_, usize, f64>,
        par: Par,
    ) -> Lblt {
        let n = symbolic.nrows();
        let threads = match par {
            Par::Seq => 1,
            Par::Rayon(threads) => threads.get(),
        };
        let mut factor = Lblt {
            values: vec![0.0; symbolic.len_val()],
            subdiag: vec![0.0; n],
            pivot_forward: vec![0; n],
            pivot_inverse: vec![0; n],
            threads,
            split: None,
            tree: row_major(symbolic).map(SupernodeTree::new),
        };
        if let (Some(supernodal), Some(tree)) = (row_major(symbolic), &factor.tree) {
            factor.split = TreeSplit::new(supernodal, tree, threads);
        }
        let mut buffer = MemBuffer::new(
            symbolic.factorize_numeric_intranode_lblt_scratch::<f64>(par, Default::default()),
        );
        symbolic.factorize_numeric_intranode_lblt(
            &mut factor.values,
            &mut factor.subdiag,
            &mut factor.pivot_forward,
            &mut factor.pivot_inverse,
            A,
            Side::Lower,
            par,
            MemStack::new(&mut buffer),
            Default::default(),
        );
        factor
    }

    /// Whether a block solve shares the tree among threads (for reports).
    pub fn splits_tree(&self) -> bool {
        self.split.is_some()
    }

    /// `A X = R` for the columns of `R`, in place, with the symbolic analysis that
    /// [`Self::factorize`] was given. A Krylov block (up to eight columns) shares the tree among
    /// the threads; wider ones share out their columns, each thread sweeping the whole factor
    /// sixteen columns at a time, which reads L less often per column, and the forward sweep
    /// of sparse columns visits only their reach (`SupernodeTree::reach`).
    /// faer's own solve runs where the row-major kernels do not apply: a simplicial factor
    /// (small problems) or a processor without AVX2 and FMA.
    pub fn solve_in_place(&self, symbolic: &SymbolicCholesky<usize>, mut rhs: MatMut<'_, f64>) {
        let width = rhs.ncols();
        if width <= 8
            && let Some(split) = &self.split
            && self.solve_rows(symbolic, rhs.rb_mut(), Some(split))
        {
            return;
        }
        let chunk = width.div_ceil(self.threads).max(1);
        let mut chunks = Vec::new();
        let mut rest = rhs;
        while rest.ncols() > 0 {
            let take = chunk.min(rest.ncols());
            let (head, tail) = rest.split_at_col_mut(take);
            chunks.push(head);
            rest = tail;
        }
        chunks
            .into_par_iter()
            .for_each(|block| self.solve_in_place_one_thread(symbolic, block));
    }

    /// The same solve on the calling thread alone.
    pub fn solve_in_place_one_thread(
        &self,
        symbolic: &SymbolicCholesky<usize>,
        mut rhs: MatMut<'_, f64>,
    ) {
        if !self.solve_rows(symbolic, rhs.rb_mut(), None) {
            self.solve_in_place_faer(symbolic, rhs);
        }
    }

    /// The row-major kernels, eight columns at a time with a split tree, sixteen without; false
    /// where they do not apply.
    fn solve_rows(
        &self,
        symbolic: &SymbolicCholesky<usize>,
        mut rhs: MatMut<'_, f64>,
        split: Option<&TreeSplit>,
    ) -> bool {
        #[cfg(target_arch = "x86_64")]
        if let Some(supernodal) = row_major(symbolic) {
            let factor = self.view(symbolic);
            let width = rhs.ncols();
            let mut first = 0;
            while first < width {
                let chunk = (width - first).min(if split.is_some() { 8 } else { 16 });
                let block = rhs.rb_mut().subcols_mut(first, chunk);
                // SAFETY: `row_major` checked AVX2 and FMA on this processor.
                unsafe {
                    if chunk <= 4 {
                        factor.solve_chunk::<4>(supernodal, split, block);
                    } else if chunk <= 8 {
                        factor.solve_chunk::<8>(supernodal, split, block);
                    } else {
                        factor.solve_chunk::<16>(supernodal, split, block);
                    }
                }
                first += chunk;
            }
            return true;
        }
        false
    }

    /// The same solve by faer's kernels on the calling thread: the fallback, and the reference
    /// of the benchmark (`SQUEAL_BENCH_SOLVE=1`).
    pub fn solve_in_place_faer(&self, symbolic: &SymbolicCholesky<usize>, rhs: MatMut<'_, f64>) {
        let factor = self.view(symbolic);
        let mut buffer =
            MemBuffer::new(symbolic.solve_in_place_scratch::<f64>(rhs.ncols(), Par::Seq));
        IntranodeLbltRef::new(symbolic, factor.values, factor.subdiag, factor.pivots)
            .solve_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut buffer));
    }

    fn view<'a>(&'a self, symbolic: &'a SymbolicCholesky<usize>) -> LbltFactor<'a> {
        LbltFactor {
            symbolic,
            values: &self.values,
            subdiag: &self.subdiag,
            pivots: PermRef::new_checked(
                &self.pivot_forward,
                &self.pivot_inverse,
                symbolic.nrows(),
            ),
            tree: self.tree.as_ref(),
        }
    }

    /// Entries of the factor in 2×2 pivots (for tests).
    #[cfg(test)]
    fn two_by_two_entries(&self) -> usize {
        self.subdiag.iter().filter(|value| **value != 0.0).count()
    }
}

/// The supernodal structure, when the row-major kernels apply to it on this processor.
fn row_major(symbolic: &SymbolicCholesky<usize>) -> Option<&SymbolicSupernodalCholesky<usize>> {
    #[cfg(target_arch = "x86_64")]
    if let SymbolicCholeskyRaw::Supernodal(supernodal) = symbolic.raw()
        && is_x86_feature_detected!("avx2")
        && is_x86_feature_detected!("fma")
    {
        return Some(supernodal);
    }
    None
}

/// A view of the factor, for the row-major kernels.
#[derive(Clone, Copy)]
struct LbltFactor<'a> {
    symbolic: &'a SymbolicCholesky<usize>,
    values: &'a [f64],
    subdiag: &'a [f64],
    pivots: PermRef<'a, usize>,
    tree: Option<&'a SupernodeTree>,
}

impl LbltFactor<'_> {
    /// Up to K columns, padded to K in the row-major work array. With a `split`, the subtrees
    /// of each group are swept by their own thread on a private copy of x, and merged.
    ///
    /// # Safety
    /// The processor must have AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    unsafe fn solve_chunk<const K: usize>(
        &self,
        symbolic: &SymbolicSupernodalCholesky<usize>,
        split: Option<&TreeSplit>,
        mut rhs: MatMut<'_, f64>,
    ) {
        let n = rhs.nrows();
        let width = rhs.ncols();
        let (pivot_forward, pivot_inverse) = self.pivots.arrays();
        let fill = self.symbolic.perm().map(|perm| perm.arrays());
        let source = |i: usize| match fill {
            Some((forward, _)) => forward[pivot_forward[i]],
            None => pivot_forward[i],
        };
        let mut x = vec![[0.0f64; K]; n];
        for j in 0..width {
            for (i, row) in x.iter_mut().enumerate() {
                row[j] = rhs[(source(i), j)];
            }
        }
        let all: Vec<usize> = (0..symbolic.n_supernodes()).collect();
        // SAFETY (every call below): the caller checked AVX2 and FMA.
        match split {
            None => {
                // A sparse block (the contact correction's columns) sweeps only its reach.
                let reach = self.tree.and_then(|tree| tree.reach(&x));
                unsafe { self.forward::<K>(symbolic, &mut x, reach.as_deref().unwrap_or(&all)) }
            }
            Some(split) => {
                let copies = on_copies(&x, &split.groups, |copy, group| unsafe {
                    self.forward::<K>(symbolic, copy, group)
                });
                // A group's rows come from its copy; the top's add every group's update.
                for (i, row) in x.iter_mut().enumerate() {
                    match split.owner[i] {
                        Some(group) => *row = copies[group][i],
                        None => {
                            let before = *row;
                            for copy in &copies {
                                for j in 0..K {
                                    row[j] += copy[i][j] - before[j];
                                }
                            }
                        }
                    }
                }
                unsafe { self.forward::<K>(symbolic, &mut x, &split.top) };
            }
        }
        self.diagonal(symbolic, &mut x);
        match split {
            None => unsafe { self.backward::<K>(symbolic, &mut x, &all) },
            Some(split) => {
                unsafe { self.backward::<K>(symbolic, &mut x, &split.top) };
                let copies = on_copies(&x, &split.groups, |copy, group| unsafe {
                    self.backward::<K>(symbolic, copy, group)
                });
                for (i, row) in x.iter_mut().enumerate() {
                    if let Some(group) = split.owner[i] {
                        *row = copies[group][i];
                    }
                }
            }
        }
        for i in 0..n {
            let at = match fill {
                Some((_, inverse)) => pivot_inverse[inverse[i]],
                None => pivot_inverse[i],
            };
            for j in 0..width {
                rhs[(i, j)] = x[at][j];
            }
        }
    }

    /// The forward sweep over `supernodes` (increasing).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn forward<const K: usize>(
        &self,
        symbolic: &SymbolicSupernodalCholesky<usize>,
        x: &mut [[f64; K]],
        supernodes: &[usize],
    ) {
        let pivot_inverse = self.pivots.arrays().1;
        let mut scratch: Vec<[f64; K]> = Vec::new();
        for &s in supernodes {
            let (start, size, pattern, L) = supernode(symbolic, self.values, s);
            let rows = size + pattern.len();
            let x_top = &mut x[start..start + size];
            unit_lower_solve(L, rows, size, x_top);
            scratch.clear();
            scratch.resize(pattern.len(), [0.0; K]);
            below_times(L, rows, size, x_top, &mut scratch);
            for (&row, update) in pattern.iter().zip(&scratch) {
                let target = &mut x[pivot_inverse[row]];
                for j in 0..K {
                    target[j] -= update[j];
                }
            }
        }
    }

    /// The backward sweep over `supernodes` (taken in decreasing order).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn backward<const K: usize>(
        &self,
        symbolic: &SymbolicSupernodalCholesky<usize>,
        x: &mut [[f64; K]],
        supernodes: &[usize],
    ) {
        let pivot_inverse = self.pivots.arrays().1;
        let mut scratch: Vec<[f64; K]> = Vec::new();
        for &s in supernodes.iter().rev() {
            let (start, size, pattern, L) = supernode(symbolic, self.values, s);
            let rows = size + pattern.len();
            scratch.clear();
            scratch.extend(pattern.iter().map(|&row| x[pivot_inverse[row]]));
            let x_top = &mut x[start..start + size];
            below_transpose_times(L, rows, size, &scratch, x_top);
            unit_upper_transpose_solve(L, rows, size, x_top);
        }
    }

    /// `x ← B⁻¹ x`, B's 1×1 and 2×2 blocks.
    fn diagonal<const K: usize>(
        &self,
        symbolic: &SymbolicSupernodalCholesky<usize>,
        x: &mut [[f64; K]],
    ) {
        for s in 0..symbolic.n_supernodes() {
            let (start, size, pattern, L) = supernode(symbolic, self.values, s);
            let rows = size + pattern.len();
            let diagonal = |index: usize| L[index * rows + index];
            let mut index = 0;
            while index < size {
                let i = start + index;
                let off_diagonal = self.subdiag[i];
                if off_diagonal == 0.0 {
                    let d = diagonal(index).recip();
                    x[i].iter_mut().for_each(|value| *value *= d);
                    index += 1;
                } else {
                    // The 2×2 block [b₁₁ s; s b₂₂], inverted as faer does.
                    let d21 = off_diagonal.recip();
                    let d11 = d21 * diagonal(index);
                    let d22 = d21 * diagonal(index + 1);
                    let denominator = (d11 * d22 - 1.0).recip();
                    let (head, tail) = x.split_at_mut(i + 1);
                    for (first, second) in head[i].iter_mut().zip(tail[0].iter_mut()) {
                        let (xk, xk1) = (*first * d21, *second * d21);
                        *first = (d22 * xk - xk1) * denominator;
                        *second = (d11 * xk1 - xk) * denominator;
                    }
                    index += 2;
                }
            }
        }
    }
}

/// The supernodal elimination tree: a supernode's parent holds the first row below its
/// diagonal block, and parents come after their children.
struct SupernodeTree {
    /// Per row (of the factor's order): its supernode.
    supernode_of: Vec<usize>,
    parent: Vec<Option<usize>>,
}

impl SupernodeTree {
    fn new(symbolic: &SymbolicSupernodalCholesky<usize>) -> SupernodeTree {
        let count = symbolic.n_supernodes();
        let (begin, end) = (symbolic.supernode_begin(), symbolic.supernode_end());
        let mut supernode_of = vec![0; symbolic.nrows()];
        for s in 0..count {
            supernode_of[begin[s]..end[s]].fill(s);
        }
        let parent = (0..count)
            .map(|s| {
                let pattern = symbolic.supernode(s).pattern();
                pattern.iter().min().map(|&row| supernode_of[row])
            })
            .collect();
        SupernodeTree {
            supernode_of,
            parent,
        }
    }

    /// The supernodes a forward sweep must visit for right-hand sides whose nonzero rows are
    /// those of `x` (the reach: the paths from their supernodes to the roots), increasing; the
    /// others see only zeros. `None` when the reach holds most of the tree.
    fn reach<const K: usize>(&self, x: &[[f64; K]]) -> Option<Vec<usize>> {
        let count = self.parent.len();
        let mut marked = vec![false; count];
        let mut reached = 0;
        for (row, values) in x.iter().enumerate() {
            if values.iter().all(|&value| value == 0.0) {
                continue;
            }
            let mut node = Some(self.supernode_of[row]);
            while let Some(s) = node.filter(|&s| !marked[s]) {
                marked[s] = true;
                reached += 1;
                node = self.parent[s];
            }
        }
        (reached < count * 3 / 4).then(|| (0..count).filter(|&s| marked[s]).collect())
    }
}

/// The supernodal elimination tree cut for `parts` threads: whole subtrees in groups of about
/// equal work, and the supernodes above them (the top), which one thread sweeps. A subtree
/// updates only its own rows and the top's, so groups run on private copies of x.
pub struct TreeSplit {
    /// Supernodes of the top, increasing.
    top: Vec<usize>,
    /// Supernodes of each group, increasing.
    groups: Vec<Vec<usize>>,
    /// Per row: its group, or `None` for the top.
    owner: Vec<Option<usize>>,
}

impl TreeSplit {
    /// Cuts the tree below its heaviest nodes until the groups (longest-processing-time
    /// assignment of the subtrees) are within 5 % of even; `None` if the top would hold more
    /// than a third of the work, or for fewer than two parts.
    fn new(
        symbolic: &SymbolicSupernodalCholesky<usize>,
        tree: &SupernodeTree,
        parts: usize,
    ) -> Option<TreeSplit> {
        let count = symbolic.n_supernodes();
        if parts < 2 || count < 2 {
            return None;
        }
        let (begin, end) = (symbolic.supernode_begin(), symbolic.supernode_end());
        let mut children = vec![Vec::new(); count];
        let mut roots = Vec::new();
        let mut work = vec![0.0; count];
        for s in 0..count {
            let size = end[s] - begin[s];
            work[s] += ((size + symbolic.supernode(s).pattern().len()) * size) as f64;
            match tree.parent[s] {
                Some(parent) => {
                    work[parent] += work[s];
                    children[parent].push(s);
                }
                None => roots.push(s),
            }
        }
        // `work` is now each subtree's; the top's own work is the node's less its children's.
        let own = |s: usize| work[s] - children[s].iter().map(|&c| work[c]).sum::<f64>();
        let total: f64 = roots.iter().map(|&s| work[s]).sum();
        let (mut frontier, mut top, mut top_work) = (roots, Vec::new(), 0.0);
        let bins = loop {
            frontier.sort_by(|&a, &b| work[b].total_cmp(&work[a]));
            let mut bins: Vec<(f64, Vec<usize>)> = vec![(0.0, Vec::new()); parts];
            for &s in &frontier {
                let lightest = (0..parts)
                    .min_by(|&a, &b| bins[a].0.total_cmp(&bins[b].0))
                    .expect("parts ≥ 2");
                bins[lightest].0 += work[s];
                bins[lightest].1.push(s);
            }
            let heaviest_bin = bins.iter().map(|bin| bin.0).fold(0.0, f64::max);
            if heaviest_bin <= 1.05 * (total - top_work) / parts as f64 {
                break bins;
            }
            let heaviest = frontier[0];
            if children[heaviest].is_empty() || top_work + own(heaviest) > total / 3.0 {
                return None;
            }
            frontier.remove(0);
            top.push(heaviest);
            top_work += own(heaviest);
            frontier.extend(children[heaviest].iter().copied());
        };
        let mut owner = vec![None; symbolic.nrows()];
        let groups = bins
            .into_iter()
            .enumerate()
            .map(|(group, (_, roots))| {
                let mut members = Vec::new();
                let mut stack = roots;
                while let Some(s) = stack.pop() {
                    members.push(s);
                    stack.extend(children[s].iter().copied());
                }
                members.sort_unstable();
                for &s in &members {
                    owner[begin[s]..end[s]].fill(Some(group));
                }
                members
            })
            .collect();
        top.sort_unstable();
        Some(TreeSplit { top, groups, owner })
    }
}

/// Each group's `sweep` on its own copy of x, the groups in parallel.
fn on_copies<const K: usize>(
    x: &[[f64; K]],
    groups: &[Vec<usize>],
    sweep: impl Fn(&mut [[f64; K]], &[usize]) + Sync,
) -> Vec<Vec<[f64; K]>> {
    groups
        .par_iter()
        .map(|group| {
            let mut copy = x.to_vec();
            sweep(&mut copy, group);
            copy
        })
        .collect()
}

/// Supernode `s`: first column, width, row pattern below, and its values (column-major,
/// `size + pattern.len()` rows).
#[inline(always)]
fn supernode<'a>(
    symbolic: &'a SymbolicSupernodalCholesky<usize>,
    values: &'a [f64],
    s: usize,
) -> (usize, usize, &'a [usize], &'a [f64]) {
    let node = symbolic.supernode(s);
    let (start, pattern) = (node.start(), node.pattern());
    let size = symbolic.supernode_end()[s] - start;
    let value_ptr = symbolic.col_ptr_for_val();
    let L = &values[value_ptr[s]..value_ptr[s + 1]];
    debug_assert_eq!(L.len(), (size + pattern.len()) * size);
    (start, size, pattern, L)
}

/// `x ← L_top⁻¹ x` (unit lower triangle, column by column).
#[inline(always)]
fn unit_lower_solve<const K: usize>(L: &[f64], rows: usize, size: usize, x: &mut [[f64; K]]) {
    for c in 0..size {
        let pivot = x[c];
        let column = &L[c * rows + c + 1..c * rows + size];
        for (xr, &l) in x[c + 1..size].iter_mut().zip(column) {
            for j in 0..K {
                xr[j] = (-l).mul_add(pivot[j], xr[j]);
            }
        }
    }
}

/// `y += L_bot x`, four columns of L per sweep over y.
#[inline(always)]
fn below_times<const K: usize>(
    L: &[f64],
    rows: usize,
    size: usize,
    x: &[[f64; K]],
    y: &mut [[f64; K]],
) {
    let column = |c: usize| &L[c * rows + size..c * rows + rows];
    let mut c = 0;
    while c + 4 <= size {
        let (x0, x1, x2, x3) = (x[c], x[c + 1], x[c + 2], x[c + 3]);
        let columns = column(c)
            .iter()
            .zip(column(c + 1))
            .zip(column(c + 2))
            .zip(column(c + 3));
        for (yr, (((&a, &b), &d), &e)) in y.iter_mut().zip(columns) {
            for j in 0..K {
                yr[j] = a.mul_add(
                    x0[j],
                    b.mul_add(x1[j], d.mul_add(x2[j], e.mul_add(x3[j], yr[j]))),
                );
            }
        }
        c += 4;
    }
    for (c, xc) in x.iter().enumerate().take(size).skip(c) {
        for (yr, &l) in y.iter_mut().zip(column(c)) {
            for j in 0..K {
                yr[j] = l.mul_add(xc[j], yr[j]);
            }
        }
    }
}

/// `x −= L_botᵀ y`, four columns of L per sweep over y.
#[inline(always)]
fn below_transpose_times<const K: usize>(
    L: &[f64],
    rows: usize,
    size: usize,
    y: &[[f64; K]],
    x: &mut [[f64; K]],
) {
    let column = |c: usize| &L[c * rows + size..c * rows + rows];
    let mut c = 0;
    while c + 4 <= size {
        let mut sums = [[0.0; K]; 4];
        let columns = column(c)
            .iter()
            .zip(column(c + 1))
            .zip(column(c + 2))
            .zip(column(c + 3));
        for (yr, (((&a, &b), &d), &e)) in y.iter().zip(columns) {
            for j in 0..K {
                sums[0][j] = a.mul_add(yr[j], sums[0][j]);
                sums[1][j] = b.mul_add(yr[j], sums[1][j]);
                sums[2][j] = d.mul_add(yr[j], sums[2][j]);
                sums[3][j] = e.mul_add(yr[j], sums[3][j]);
            }
        }
        for (xc, sum) in x[c..c + 4].iter_mut().zip(&sums) {
            for j in 0..K {
                xc[j] -= sum[j];
            }
        }
        c += 4;
    }
    for (c, xc) in x.iter_mut().enumerate().take(size).skip(c) {
        let mut sum = [0.0; K];
        for (yr, &l) in y.iter().zip(column(c)) {
            for j in 0..K {
                sum[j] = l.mul_add(yr[j], sum[j]);
            }
        }
        for j in 0..K {
            xc[j] -= sum[j];
        }
    }
}

/// `x ← L_top⁻ᵀ x` (unit upper triangle), last row first.
#[inline(always)]
fn unit_upper_transpose_solve<const K: usize>(
    L: &[f64],
    rows: usize,
    size: usize,
    x: &mut [[f64; K]],
) {
    for c in (0..size).rev() {
        let column = &L[c * rows + c + 1..c * rows + size];
        let mut sum = [0.0; K];
        for (xr, &l) in x[c + 1..size].iter().zip(column) {
            for j in 0..K {
                sum[j] = l.mul_add(xr[j], sum[j]);
            }
        }
        for j in 0..K {
            x[c][j] -= sum[j];
        }
    }
}

#[cfg(test)]
mod tests {
    use faer::Mat;
    use faer::sparse::SymbolicSparseColMatRef;
    use faer::sparse::linalg::SupernodalThreshold;
    use faer::sparse::linalg::cholesky::{
        CholeskySymbolicParams, SymmetricOrdering, factorize_symbolic_cholesky,
    };

    use super::*;
    use crate::rng::SplitMix64;

    /// A symmetric indefinite matrix on a 24 × 24 grid (lower triangle, CSC): random couplings
    /// to the right and above neighbours and a small random diagonal, so that Bunch–Kaufman
    /// needs 2×2 pivots.
    fn indefinite_grid() -> (usize, Vec<usize>, Vec<usize>, Vec<f64>) {
        let side = 24;
        let n = side * side;
        let mut random = SplitMix64::new(7);
        let (mut col_ptr, mut row_idx, mut values) = (vec![0], Vec::new(), Vec::new());
        for col in 0..n {
            row_idx.push(col);
            values.push(0.1 * random.next_signed());
            for neighbour in [col + 1, col + side] {
                let same_row = neighbour != col + 1 || (col + 1) % side != 0;
                if neighbour < n && same_row {
                    row_idx.push(neighbour);
                    values.push(1.0 + 0.5 * random.next_signed());
                }
            }
            col_ptr.push(row_idx.len());
        }
        (n, col_ptr, row_idx, values)
    }

    #[test]
    fn the_row_major_solve_equals_faer_and_leaves_a_round_off_residual() {
        let (n, col_ptr, row_idx, values) = indefinite_grid();
        let A = SparseColMatRef::new(
            SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx),
            &values,
        );
        // ‖A‖∞, the largest absolute row sum.
        let mut row_sums = vec![0.0; n];
        for col in 0..n {
            for entry in col_ptr[col]..col_ptr[col + 1] {
                row_sums[row_idx[entry]] += values[entry].abs();
                if row_idx[entry] != col {
                    row_sums[col] += values[entry].abs();
                }
            }
        }
        let norm_inf = row_sums.iter().copied().fold(0.0, f64::max);
        for threshold in [
            SupernodalThreshold::FORCE_SUPERNODAL,
            SupernodalThreshold::FORCE_SIMPLICIAL,
        ] {
            let symbolic = factorize_symbolic_cholesky(
                A.symbolic(),
                Side::Lower,
                SymmetricOrdering::Amd,
                CholeskySymbolicParams {
                    supernodal_flop_ratio_threshold: threshold,
                    ..Default::default()
                },
            )
            .unwrap();
            let supernodal = matches!(symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_));
            // One thread, and the tree shared among two and three.
            for threads in [1, 2, 3] {
                let par = if threads == 1 {
                    Par::Seq
                } else {
                    Par::rayon(threads)
                };
                let factor = Lblt::factorize(&symbolic, A, par);
                let two_by_two = factor.two_by_two_entries();
                // faer pivots only inside supernodes.
                assert_eq!(supernodal, two_by_two > 0, "2×2 pivots: {two_by_two}");
                if let Some(split) = &factor.split {
                    eprintln!(
                        "{threads} threads: top {} supernodes, groups {:?}",
                        split.top.len(),
                        split.groups.iter().map(Vec::len).collect::<Vec<_>>()
                    );
                }
                assert_eq!(
                    factor.splits_tree(),
                    supernodal && threads > 1 && row_major(&symbolic).is_some()
                );
                if let Some(tree) = &factor.tree {
                    // One nonzero row reaches the path from its supernode to a root.
                    let mut x = vec![[0.0; 1]; n];
                    x[n / 2][0] = 1.0;
                    let reach = tree.reach(&x).expect("a path, not most of the tree");
                    assert!(reach.windows(2).all(|pair| pair[0] < pair[1]));
                    assert_eq!(reach[0], tree.supernode_of[n / 2]);
                    assert!(tree.parent[*reach.last().unwrap()].is_none());
                }
                let mut random = SplitMix64::new(11);
                // Widths below, at and above the kernel widths (4, 8 and 16), and over two
                // chunks.
                // Sparse columns too (three nonzeros each, as the contact correction's), whose
                // forward sweep visits only their reach.
                let cases = [1, 3, 4, 5, 8, 11, 16, 37].map(|width| (width, false));
                let sparse_cases = [(1, true), (4, true), (16, true), (37, true)];
                for (width, sparse) in cases.into_iter().chain(sparse_cases) {
                    let B = Mat::<f64>::from_fn(n, width, |row, col| {
                        let kept = !sparse || (row * 7 + col * 131) % n < 3;
                        if kept { random.next_signed() } else { 0.0 }
                    });
                    let mut X = B.clone();
                    factor.solve_in_place(&symbolic, X.as_mut());
                    let mut reference = B.clone();
                    factor.solve_in_place_faer(&symbolic, reference.as_mut());
                    let difference = (&X - &reference).norm_max() / reference.norm_max();
                    assert!(
                        difference <= 1e-12,
                        "width {width} (sparse: {sparse}): {difference:e} from faer"
                    );
                    // A X − B, with A applied from its lower triangle.
                    let mut residual = -B.clone();
                    for col in 0..n {
                        for entry in col_ptr[col]..col_ptr[col + 1] {
                            let (row, value) = (row_idx[entry], values[entry]);
                            for j in 0..width {
                                residual[(row, j)] += value * X[(col, j)];
                                if row != col {
                                    residual[(col, j)] += value * X[(row, j)];
                                }
                            }
                        }
                    }
                    let backward_error =
                        residual.norm_max() / (norm_inf * X.norm_max() + B.norm_max());
                    assert!(
                        backward_error <= 1e-12,
                        "width {width} (sparse: {sparse}): backward error {backward_error:e}"
                    );
                }
                eprintln!(
                    "{n} unknowns, {two_by_two} entries in 2×2 pivots, supernodal: {supernodal}"
                );
            }
        }
    }
}

//! `A⁻¹` stored dense, one block per connected component of `A`'s pattern, for the split
//! solve of [`crate::cholesky`] (`A x = b + Gᵀ r`, `r` known only from `G A⁻¹ b`):
//!
//! ```text
//! x_free = A⁻¹ b,    g_free = G x_free,    r from g_free,    x = A⁻¹ (b + Gᵀ r)
//! ```
//!
//! with the Delassus operator `W = G A⁻¹ Gᵀ` read off the blocks. A reduced model whose
//! bodies meet only through their contact (the bodies kept whole) has a few components, each
//! dense: a body's static modes couple all of its interface. Its factor is then as dense, and
//! a split solve by it reads the factor twice and `Y = L⁻¹ Pᵀ Gᵀ` twice, where two passes over
//! the inverse's lower triangles read no more than the factor's entries twice. Each pass
//! reads a column of a block's lower triangle once, for its row and its column at once
//! ([`dot_and_axpy`]), in a fixed order: the bits do not depend on the thread count. The
//! second pass skips the blocks that `G` does not reach, whose right-hand side it leaves as
//! it was.
//!
//! Each block is inverted through the Cholesky factor of its matrix scaled to a unit diagonal,
//! `Â = D^{-½} A D^{-½}`, `A⁻¹ = D^{-½} Â⁻¹ D^{-½}`: the scaling takes out the spread of the
//! unknowns' units (a reduced model's interface displacements and modal coordinates), and
//! what rounding the explicit inverse adds grows with the condition of `Â`, not of `A`.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::inverse::{inverse, inverse_scratch};
use faer::{Mat, Par};

use crate::Error;
use crate::cholesky::{Analysis, Combination, rows_times};
use crate::csc::{self, CscMatrix};
use crate::dense;
use crate::kernels::dot_and_axpy;

/// The connected components of a symmetric pattern ([`csc::components`]): the blocks a
/// [`BlockInverse`] stores.
pub struct Components {
    /// Each component's unknowns, ascending; the components by their first unknown.
    members: Vec<Vec<usize>>,
}

impl Components {
    /// The components of the union of the patterns of `matrices`.
    pub fn of(matrices: &[&CscMatrix]) -> Components {
        Components {
            members: csc::components(matrices),
        }
    }

    /// Entries of the blocks' lower triangles: what a [`BlockInverse`] stores.
    pub fn dense_len(&self) -> usize {
        self.members
            .iter()
            .map(|unknowns| unknowns.len() * (unknowns.len() + 1) / 2)
            .sum()
    }
}

/// One component's inverse.
struct Block {
    /// Its unknowns, ascending.
    unknowns: Vec<usize>,
    /// The lower triangle by columns: column `j` holds rows `j..`, from `offset(j)`.
    lower: Vec<f64>,
    /// `κ₁(Â) = ‖Â‖₁ ‖Â⁻¹‖₁` of the block scaled to a unit diagonal.
    condition: f64,
}

impl Block {
    fn offset(&self, j: usize) -> usize {
        let n = self.unknowns.len();
        j * (2 * n - j + 1) / 2
    }

    /// Entry `(i, j)` of the inverse (local indices).
    fn entry(&self, i: usize, j: usize) -> f64 {
        let (low, high) = (i.min(j), i.max(j));
        self.lower[self.offset(low) + high - low]
    }

    /// `out = A⁻¹ b` on this block's unknowns, `local` two work vectors.
    fn apply(&self, b: &[f64], out: &mut [f64], local: &mut (Vec<f64>, Vec<f64>)) {
        let n = self.unknowns.len();
        let (x, y) = local;
        x.clear();
        x.extend(self.unknowns.iter().map(|&unknown| b[unknown]));
        y.clear();
        y.resize(n, 0.0);
        let mut offset = 0;
        for j in 0..n {
            let column = &self.lower[offset..offset + n - j];
            let (head, below) = y.split_at_mut(j + 1);
            let from_below = dot_and_axpy(&column[1..], &x[j + 1..], x[j], below);
            head[j] += column[0] * x[j] + from_below;
            offset += n - j;
        }
        for (&unknown, &value) in self.unknowns.iter().zip(y.iter()) {
            out[unknown] = value;
        }
    }
}

/// `A⁻¹` by dense blocks (module doc).
pub struct BlockInverse {
    n: usize,
    blocks: Vec<Block>,
}

impl BlockInverse {
    /// Inverts `A = Σ cᵢ Aᵢ`, as `analysis` combined it ([`crate::cholesky::Cholesky::analyse`]), block by
    /// block over `components`, those of the terms' patterns ([`Components::of`]).
    pub fn new(analysis: &Analysis, components: &Components) -> Result<BlockInverse, Error> {
        let combination = &analysis.combination;
        let blocks = components
            .members
            .iter()
            .map(|unknowns| {
                let (lower, condition) = inverse_lower(combination, unknowns)?;
                Ok(Block {
                    lower,
                    condition,
                    unknowns: unknowns.clone(),
                })
            })
            .collect::<Result<Vec<_>, Error>>()?;
        Ok(BlockInverse {
            n: combination.n,
            blocks,
        })
    }

    /// Entries stored: the blocks' lower triangles.
    pub fn entries(&self) -> usize {
        self.blocks.iter().map(|block| block.lower.len()).sum()
    }

    /// The largest condition number `κ₁(Â)` of the blocks scaled to a unit diagonal: a
    /// product by the inverse leaves a residual of about `κ₁(Â) ε ‖b‖` (scaled), where a
    /// solve by the factor leaves `ε ‖A‖ ‖x‖`.
    pub fn condition(&self) -> f64 {
        self.blocks
            .iter()
            .map(|block| block.condition)
            .fold(0.0, f64::max)
    }
}

/// The split solve by a [`BlockInverse`] for the contact rows `G`, with `W = G A⁻¹ Gᵀ`.
pub struct BlockInterfaceSolve {
    /// `G`'s rows: `(unknown, coefficient)`.
    G_rows: Vec<Vec<(usize, f64)>>,
    /// Whether `G` reaches each block.
    in_contact: Vec<bool>,
    /// The Delassus operator `G A⁻¹ Gᵀ`, exactly symmetric.
    pub W: Mat<f64>,
}

impl BlockInterfaceSolve {
    /// # Panics
    /// If a row of `G` reaches an unknown out of `inverse`'s range.
    pub fn new(inverse: &BlockInverse, G_rows: &[Vec<(usize, f64)>]) -> BlockInterfaceSolve {
        let n = inverse.n;
        let mut reaches = vec![false; n];
        for &(unknown, _) in G_rows.iter().flatten() {
            reaches[unknown] = true;
        }
        let in_contact = inverse
            .blocks
            .iter()
            .map(|block| block.unknowns.iter().any(|&unknown| reaches[unknown]))
            .collect();
        BlockInterfaceSolve {
            W: delassus(inverse, G_rows),
            G_rows: G_rows.to_vec(),
            in_contact,
        }
    }

    /// Unknowns of the blocks that `G` reaches: those the contact's correction rewrites.
    pub fn contact_rows(&self, inverse: &BlockInverse) -> usize {
        inverse
            .blocks
            .iter()
            .zip(&self.in_contact)
            .filter(|(_, in_contact)| **in_contact)
            .map(|(block, _)| block.unknowns.len())
            .sum()
    }

    /// `x = A⁻¹ (b + Gᵀ r)` (`b`, `x` indexed by unknown), `r` chosen by `react` from the free
    /// contact quantities `G A⁻¹ b`, written to `g_free`; `y` is a work vector of `n` values
    /// (as [`crate::cholesky::InterfaceSolve::solve`]).
    pub fn solve<'r, E>(
        &self,
        inverse: &BlockInverse,
        b: &[f64],
        (g_free, y, x): (&mut [f64], &mut [f64], &mut [f64]),
        react: impl FnOnce(&[f64]) -> Result<&'r [f64], E>,
    ) -> Result<(), E> {
        let mut local = (Vec::new(), Vec::new());
        for block in &inverse.blocks {
            block.apply(b, x, &mut local);
        }
        rows_times(&self.G_rows, x, g_free);
        let r = react(g_free)?;
        y.copy_from_slice(b);
        for (row, &r_row) in self.G_rows.iter().zip(r) {
            for &(unknown, value) in row {
                y[unknown] += value * r_row;
            }
        }
        for (block, _) in inverse
            .blocks
            .iter()
            .zip(&self.in_contact)
            .filter(|(_, in_contact)| **in_contact)
        {
            block.apply(y, x, &mut local);
        }
        Ok(())
    }
}

/// `G A⁻¹ Gᵀ`, its lower triangle mirrored.
fn delassus(inverse: &BlockInverse, G_rows: &[Vec<(usize, f64)>]) -> Mat<f64> {
    let m = G_rows.len();
    // Where each unknown sits: (block, local index).
    let mut place = vec![(usize::MAX, 0); inverse.n];
    for (b, block) in inverse.blocks.iter().enumerate() {
        for (local, &unknown) in block.unknowns.iter().enumerate() {
            place[unknown] = (b, local);
        }
    }
    // The unknowns G reaches, by block.
    let mut reached: Vec<usize> = G_rows
        .iter()
        .flatten()
        .map(|&(unknown, _)| unknown)
        .collect();
    reached.sort_unstable();
    reached.dedup();
    let mut index = vec![usize::MAX; inverse.n];
    let mut by_block: Vec<Vec<(usize, usize)>> = vec![Vec::new(); inverse.blocks.len()];
    for (k, &unknown) in reached.iter().enumerate() {
        index[unknown] = k;
        let (b, local) = place[unknown];
        by_block[b].push((k, local));
    }
    // T = A⁻¹ Gᵀ on the reached unknowns, then W = G T.
    let mut T = Mat::<f64>::zeros(reached.len(), m);
    for (a, row) in G_rows.iter().enumerate() {
        for &(unknown, coefficient) in row {
            let (b, j) = place[unknown];
            let block = &inverse.blocks[b];
            for &(k, i) in &by_block[b] {
                T[(k, a)] += coefficient * block.entry(i, j);
            }
        }
    }
    let mut W = Mat::<f64>::zeros(m, m);
    for a in 0..m {
        for (c, row) in G_rows.iter().enumerate().skip(a) {
            let value: f64 = row
                .iter()
                .map(|&(unknown, coefficient)| coefficient * T[(index[unknown], a)])
                .sum();
            W[(c, a)] = value;
            W[(a, c)] = value;
        }
    }
    W
}

/// The lower triangle of the inverse of `A` restricted to `unknowns` (a component, so
/// nothing couples it to the rest), packed by columns, and `κ₁` of the scaled block.
fn inverse_lower(combination: &Combination, unknowns: &[usize]) -> Result<(Vec<f64>, f64), Error> {
    let n = unknowns.len();
    let mut local = vec![usize::MAX; combination.n];
    for (i, &unknown) in unknowns.iter().enumerate() {
        local[unknown] = i;
    }
    let mut A = Mat::<f64>::zeros(n, n);
    for (j, &unknown) in unknowns.iter().enumerate() {
        let entries = combination.col_ptr[unknown]..combination.col_ptr[unknown + 1];
        for entry in entries {
            let i = local[combination.row_idx[entry]];
            A[(i, j)] = combination.values[entry];
        }
    }
    let scale: Vec<f64> = (0..n).map(|i| A[(i, i)]).collect();
    if let Some(i) = scale.iter().position(|&d| !(d > 0.0)) {
        return Err(Error::Breakdown(format!(
            "the {n} x {n} block of unknowns {}..={} is not positive definite: diagonal entry {} of unknown {}",
            unknowns[0],
            unknowns[n - 1],
            scale[i],
            unknowns[i]
        )));
    }
    let scale: Vec<f64> = scale.iter().map(|d| 1.0 / d.sqrt()).collect();
    for j in 0..n {
        for i in j..n {
            A[(i, j)] *= scale[i] * scale[j];
        }
    }
    // Column sums of |·| of a symmetric matrix from its lower triangle.
    let norm_1 = |M: &Mat<f64>| {
        let mut sums = vec![0.0_f64; n];
        for j in 0..n {
            sums[j] += M[(j, j)].abs();
            for i in j + 1..n {
                sums[i] += M[(i, j)].abs();
                sums[j] += M[(i, j)].abs();
            }
        }
        sums.into_iter().fold(0.0, f64::max)
    };
    let norm_A = norm_1(&A);
    dense::cholesky_lower(A.as_mut(), Par::Seq).map_err(|err| {
        Error::Breakdown(format!(
            "Cholesky of the {n} x {n} block of unknowns {}..={} failed: it is not positive definite ({err})",
            unknowns[0],
            unknowns[n - 1]
        ))
    })?;
    let mut buffer = MemBuffer::new(inverse_scratch::<f64>(n, Par::Seq));
    let mut X = Mat::<f64>::zeros(n, n);
    inverse(X.as_mut(), A.as_ref(), Par::Seq, MemStack::new(&mut buffer));
    let condition = norm_A * norm_1(&X);
    let mut lower = Vec::with_capacity(n * (n + 1) / 2);
    for j in 0..n {
        lower.extend((j..n).map(|i| X[(i, j)] * scale[i] * scale[j]));
    }
    Ok((lower, condition))
}

#[cfg(test)]
mod tests;

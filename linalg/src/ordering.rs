//! Fill-reducing ordering for the sparse LDLᵀ of `K − σ M`: nested dissection (METIS
//! `NodeND`) of the node graph.
//!
//! The DOFs of a node share their sparsity pattern, so the graph whose vertices are nodes (the
//! groups of DOFs of `dof_of_node`) is three times smaller than the DOF graph and gives the same
//! ordering quality; each node's DOFs are then eliminated together. On 3D solid meshes nested
//! dissection makes the factor markedly sparser and faster to compute than minimum degree.

use std::sync::Mutex;

use metis_sys as metis;
use rayon::prelude::*;

use crate::csc::CscMatrix;

/// METIS keeps its random generator in C globals: calls must not overlap, and each call sets
/// the seed, which makes the ordering (hence every digit of the results) reproducible.
static METIS_LOCK: Mutex<()> = Mutex::new(());
const METIS_SEED: metis::idx_t = 20_110_524;

/// Groups of DOFs eliminated together: the free DOFs of each node, if `dof_of_node` numbers
/// every DOF of `0..n` exactly once; otherwise one group per DOF.
pub fn dof_groups(dof_of_node: &[[Option<u32>; 3]], n: usize) -> Vec<Vec<usize>> {
    let mut seen = vec![false; n];
    let mut groups = Vec::with_capacity(dof_of_node.len());
    let mut consistent = true;
    for dofs in dof_of_node {
        let group: Vec<usize> = dofs.iter().flatten().map(|&dof| dof as usize).collect();
        for &dof in &group {
            if dof >= n || seen[dof] {
                consistent = false;
            } else {
                seen[dof] = true;
            }
        }
        if !group.is_empty() {
            groups.push(group);
        }
    }
    if consistent && seen.iter().all(|&numbered| numbered) {
        groups
    } else {
        (0..n).map(|dof| vec![dof]).collect()
    }
}

/// A nested-dissection order of the DOFs (position → DOF), from the union of the patterns of
/// `matrices`, or `None` if METIS cannot order this graph.
pub fn nested_dissection(
    groups: &[Vec<usize>],
    matrices: &[&CscMatrix],
    n: usize,
) -> Option<Vec<usize>> {
    let n_groups = groups.len();
    let mut group_of_dof = vec![0usize; n];
    for (group_idx, group) in groups.iter().enumerate() {
        for &dof in group {
            group_of_dof[dof] = group_idx;
        }
    }
    let adjacency: Vec<Vec<metis::idx_t>> = groups
        .par_iter()
        .enumerate()
        .map(|(group_idx, group)| {
            let mut neighbours: Vec<metis::idx_t> = Vec::new();
            for &dof in group {
                for matrix in matrices {
                    let rows = &matrix.row_idx[matrix.col_ptr[dof]..matrix.col_ptr[dof + 1]];
                    neighbours.extend(
                        rows.iter()
                            .map(|&row| group_of_dof[row])
                            .filter(|&other| other != group_idx)
                            .map(|other| other as metis::idx_t),
                    );
                }
            }
            neighbours.sort_unstable();
            neighbours.dedup();
            neighbours
        })
        .collect();
    let n_edges: usize = adjacency.iter().map(Vec::len).sum();
    if n_edges == 0 || n_edges > metis::idx_t::MAX as usize || n_groups < 2 {
        return None;
    }
    let mut xadj: Vec<metis::idx_t> = Vec::with_capacity(n_groups + 1);
    xadj.push(0);
    let mut adjncy: Vec<metis::idx_t> = Vec::with_capacity(n_edges);
    for neighbours in &adjacency {
        adjncy.extend_from_slice(neighbours);
        xadj.push(adjncy.len() as metis::idx_t);
    }
    let mut n_vertices = n_groups as metis::idx_t;
    let mut perm = vec![0 as metis::idx_t; n_groups];
    let mut iperm = vec![0 as metis::idx_t; n_groups];
    let mut options = [0 as metis::idx_t; metis::METIS_NOPTIONS as usize];
    let status = {
        let _guard = METIS_LOCK
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        // SAFETY: the arrays have the lengths METIS_NodeND requires (xadj: n + 1, adjncy:
        // xadj[n], perm and iperm: n, options: METIS_NOPTIONS), outlive the call, and METIS
        // does not keep pointers to them; vwgt may be null.
        unsafe {
            metis::METIS_SetDefaultOptions(options.as_mut_ptr());
            options[metis::moptions_et_METIS_OPTION_NUMBERING as usize] = 0;
            options[metis::moptions_et_METIS_OPTION_SEED as usize] = METIS_SEED;
            metis::METIS_NodeND(
                &mut n_vertices,
                xadj.as_mut_ptr(),
                adjncy.as_mut_ptr(),
                std::ptr::null_mut(),
                options.as_mut_ptr(),
                perm.as_mut_ptr(),
                iperm.as_mut_ptr(),
            )
        }
    };
    if status != metis::rstatus_et_METIS_OK as std::os::raw::c_int {
        return None;
    }
    // METIS: row i of the permuted matrix is row perm[i] of the original.
    let mut order = Vec::with_capacity(n);
    let mut placed = vec![false; n_groups];
    for &group_idx in &perm {
        let group_idx = usize::try_from(group_idx).ok()?;
        if group_idx >= n_groups || placed[group_idx] {
            return None;
        }
        placed[group_idx] = true;
        order.extend_from_slice(&groups[group_idx]);
    }
    Some(order)
}

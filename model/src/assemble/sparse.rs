//! Deterministic parallel assembly of `M`, `K` and `C` into one shared sparse pattern.
//!
//! The pattern has a dense 3×3 block for every pair of nodes that share an element (explicit
//! zeros included, so `M`, `K` and `C` have identical structure and can be combined entry by
//! entry, e.g. `K − σ M`). Because DOFs are numbered node by node, the free columns of a node
//! are consecutive and so are their values: each node's columns are filled by one task, which
//! adds the contributions of the node's elements in increasing element order. Every entry is
//! therefore the same floating-point sum whatever the number of threads, and the matrices are
//! bit-identical from run to run (the engine caches them by content hash).
//!
//! Tied nodes ([`super::ties`]) are substituted on the fly: every node a stands for the free
//! nodes m of its [`Substitution`] with weights w (a node that is not tied for itself with
//! weight 1), and an element's 3×3 block (a, b) is added to the blocks (m_a, m_b) scaled by
//! w_a w_b, which is Tᵀ K T block by block. A node's columns then gather the elements of every
//! node standing for it, still in increasing element order. Without ties every weight is
//! exactly 1 and every sum is the one made without the substitution, bit for bit; with ties
//! the terms of an entry and of its transpose may come in different orders, and the lower
//! triangle is then copied from the upper one to keep the matrices exactly symmetric.

use rayon::prelude::*;

use crate::artifact::mesh::Mesh;
use crate::artifact::{CscMatrix, TiedNode};
use crate::fem::element::{ElementMatrices, packed_index};

/// The assembled matrices over the free DOFs.
pub struct Assembled {
    pub M: CscMatrix,
    pub K: CscMatrix,
    pub C: CscMatrix,
}

/// What each node of the mesh stands for: the free nodes whose displacements make its own,
/// with their weights (compressed rows). A node that is not tied is itself with weight 1; a
/// tied node is its masters.
pub struct Substitution {
    offsets: Vec<usize>,
    terms: Vec<(u32, f64)>,
    tied: bool,
}

impl Substitution {
    /// The substitution of `tied` (sorted by node) on a mesh of `n_nodes` nodes.
    pub fn new(n_nodes: usize, tied: &[TiedNode]) -> Substitution {
        let mut offsets = Vec::with_capacity(n_nodes + 1);
        let mut terms = Vec::with_capacity(n_nodes);
        offsets.push(0);
        let mut next = tied.iter().peekable();
        for node in 0..n_nodes {
            match next.peek() {
                Some(tie) if tie.node as usize == node => {
                    terms.extend_from_slice(&tie.masters);
                    next.next();
                }
                _ => terms.push((node as u32, 1.0)),
            }
            offsets.push(terms.len());
        }
        Substitution {
            offsets,
            terms,
            tied: !tied.is_empty(),
        }
    }

    /// The (free node, weight) that `node` stands for.
    pub fn of(&self, node: usize) -> &[(u32, f64)] {
        &self.terms[self.offsets[node]..self.offsets[node + 1]]
    }

    /// The weight of `master` in what `node` stands for, if it is there.
    fn weight(&self, node: usize, master: u32) -> Option<f64> {
        self.of(node)
            .iter()
            .find(|(other, _)| *other == master)
            .map(|(_, weight)| *weight)
    }
}

/// Elements of each node, in increasing element order (compressed rows): those of the mesh
/// nodes that stand for it.
struct NodeElements {
    offsets: Vec<usize>,
    elements: Vec<u32>,
}

impl NodeElements {
    fn new(mesh: &Mesh, substitution: &Substitution) -> NodeElements {
        let mut offsets = vec![0usize; mesh.n_nodes() + 1];
        for &node in mesh.elements.all_nodes() {
            for &(master, _) in substitution.of(node as usize) {
                offsets[master as usize + 1] += 1;
            }
        }
        for node in 0..mesh.n_nodes() {
            offsets[node + 1] += offsets[node];
        }
        let mut next = offsets.clone();
        let mut elements = vec![0u32; offsets[mesh.n_nodes()]];
        for (element_idx, element) in mesh.elements.iter().enumerate() {
            for &node in element.nodes {
                for &(master, _) in substitution.of(node as usize) {
                    elements[next[master as usize]] = element_idx as u32;
                    next[master as usize] += 1;
                }
            }
        }
        NodeElements { offsets, elements }
    }

    /// Elements of `node`; an element appears once per occurrence of a node standing for it.
    fn of(&self, node: usize) -> &[u32] {
        &self.elements[self.offsets[node]..self.offsets[node + 1]]
    }
}

/// The neighbours of each free node (sorted, itself included) and, for each neighbour, how many
/// free DOFs precede it in the node's columns.
fn neighbourhoods(
    mesh: &Mesh,
    substitution: &Substitution,
    node_elements: &NodeElements,
    free_dirs: &[Vec<usize>],
) -> Vec<(Vec<u32>, Vec<usize>)> {
    (0..mesh.n_nodes())
        .into_par_iter()
        .map(|node| {
            if free_dirs[node].is_empty() {
                return (Vec::new(), vec![0]);
            }
            let mut nodes: Vec<u32> = node_elements
                .of(node)
                .iter()
                .flat_map(|&element| mesh.elements.nodes(element as usize).iter())
                .flat_map(|&other| substitution.of(other as usize).iter().map(|term| term.0))
                .collect();
            nodes.sort_unstable();
            nodes.dedup();
            let mut offsets = Vec::with_capacity(nodes.len() + 1);
            let mut count = 0;
            offsets.push(0);
            for &other in &nodes {
                count += free_dirs[other as usize].len();
                offsets.push(count);
            }
            (nodes, offsets)
        })
        .collect()
}

/// The compressed pattern (column pointers, row indices), node-major: the columns of node `n`
/// come after those of nodes `< n`.
fn pattern(
    n_dofs: usize,
    dof_of_node: &[[Option<u32>; 3]],
    free_dirs: &[Vec<usize>],
    neighbours: &[(Vec<u32>, Vec<usize>)],
) -> (Vec<usize>, Vec<usize>) {
    let mut col_ptr = Vec::with_capacity(n_dofs + 1);
    col_ptr.push(0usize);
    let mut row_idx = Vec::new();
    for (node, (nodes, offsets)) in neighbours.iter().enumerate() {
        let column_len = *offsets.last().unwrap_or(&0);
        for _ in &free_dirs[node] {
            for &other in nodes {
                for &dir in &free_dirs[other as usize] {
                    row_idx.push(dof_of_node[other as usize][dir].unwrap_or(0) as usize);
                }
            }
            col_ptr.push(col_ptr.last().unwrap_or(&0) + column_len);
        }
    }
    debug_assert_eq!(col_ptr.len(), n_dofs + 1);
    (col_ptr, row_idx)
}

/// Assembles the element matrices (`elements[e]`, damping `(α, β)` of element `e`) over the
/// free DOFs `dof_of_node` (node-major numbering, `n_dofs` in all), the tied nodes substituted
/// by their masters (`substitution`; a tied node has no DOF).
pub fn assemble(
    mesh: &Mesh,
    dof_of_node: &[[Option<u32>; 3]],
    n_dofs: usize,
    substitution: &Substitution,
    elements: &[ElementMatrices],
    damping: &[(f64, f64)],
) -> Assembled {
    let n_nodes = mesh.n_nodes();
    let node_elements = NodeElements::new(mesh, substitution);
    let free_dirs: Vec<Vec<usize>> = dof_of_node
        .iter()
        .map(|dofs| (0..3).filter(|&dir| dofs[dir].is_some()).collect())
        .collect();

    let neighbours = neighbourhoods(mesh, substitution, &node_elements, &free_dirs);
    let (col_ptr, row_idx) = pattern(n_dofs, dof_of_node, &free_dirs, &neighbours);

    let nnz = row_idx.len();
    let mut M_values = vec![0.0; nnz];
    let mut K_values = vec![0.0; nnz];
    let mut C_values = vec![0.0; nnz];
    // Split the value arrays into one disjoint slice per node (its consecutive columns).
    let mut node_slices = Vec::with_capacity(n_nodes);
    {
        let (mut M_rest, mut K_rest, mut C_rest) = (
            M_values.as_mut_slice(),
            K_values.as_mut_slice(),
            C_values.as_mut_slice(),
        );
        for node in 0..n_nodes {
            let len = free_dirs[node].len() * neighbours[node].1.last().unwrap_or(&0);
            let (M_node, M_tail) = std::mem::take(&mut M_rest).split_at_mut(len);
            let (K_node, K_tail) = std::mem::take(&mut K_rest).split_at_mut(len);
            let (C_node, C_tail) = std::mem::take(&mut C_rest).split_at_mut(len);
            (M_rest, K_rest, C_rest) = (M_tail, K_tail, C_tail);
            node_slices.push((node, M_node, K_node, C_node));
        }
    }
    node_slices
        .into_par_iter()
        .for_each(|(node, M_node, K_node, C_node)| {
            let column_dirs = &free_dirs[node];
            if column_dirs.is_empty() {
                return;
            }
            let (nodes, offsets) = &neighbours[node];
            let column_len = offsets[offsets.len() - 1];
            let mut previous_element = None;
            for &element_idx in node_elements.of(node) {
                // A node listed twice in an element makes it degenerate, which is rejected
                // before assembly; skipping repeats keeps every contribution counted once.
                if previous_element == Some(element_idx) {
                    continue;
                }
                previous_element = Some(element_idx);
                let element_idx = element_idx as usize;
                let element_nodes = mesh.elements.nodes(element_idx);
                let matrices = &elements[element_idx];
                let (alpha, beta) = damping[element_idx];
                // Every local node standing for this one (itself when nothing is tied).
                for (local_col, &column_node) in element_nodes.iter().enumerate() {
                    let Some(column_weight) =
                        substitution.weight(column_node as usize, node as u32)
                    else {
                        continue;
                    };
                    for (local_row, &row_node) in element_nodes.iter().enumerate() {
                        for &(other, row_weight) in substitution.of(row_node as usize) {
                            let Ok(neighbour) = nodes.binary_search(&other) else {
                                continue;
                            };
                            let weight = row_weight * column_weight;
                            let row_base = offsets[neighbour];
                            for (column_rank, &col_dir) in column_dirs.iter().enumerate() {
                                let element_col = 3 * local_col + col_dir;
                                for (row_rank, &row_dir) in
                                    free_dirs[other as usize].iter().enumerate()
                                {
                                    let element_row = 3 * local_row + row_dir;
                                    let position = column_rank * column_len + row_base + row_rank;
                                    let stiffness =
                                        matrices.stiffness[packed_index(element_row, element_col)];
                                    let mass = if row_dir == col_dir {
                                        matrices.mass[packed_index(local_row, local_col)]
                                    } else {
                                        0.0
                                    };
                                    K_node[position] += weight * stiffness;
                                    M_node[position] += weight * mass;
                                    C_node[position] += weight * (alpha * mass + beta * stiffness);
                                }
                            }
                        }
                    }
                    if !substitution.tied {
                        // The node itself, once: an element listing a node twice is
                        // degenerate and refused before assembly.
                        break;
                    }
                }
            }
        });

    if substitution.tied {
        for values in [&mut M_values, &mut K_values, &mut C_values] {
            mirror_upper(&col_ptr, &row_idx, values);
        }
    }
    let matrix = |col_ptr: Vec<usize>, row_idx: Vec<usize>, values: Vec<f64>| CscMatrix {
        n_rows: n_dofs,
        n_cols: n_dofs,
        col_ptr,
        row_idx,
        values,
    };
    // Two copies of the pattern; the third matrix takes the original.
    Assembled {
        M: matrix(col_ptr.clone(), row_idx.clone(), M_values),
        K: matrix(col_ptr.clone(), row_idx.clone(), K_values),
        C: matrix(col_ptr, row_idx, C_values),
    }
}

/// Copies each entry above the diagonal to its mirror below it, in a pattern that is
/// symmetric: the matrix becomes exactly symmetric.
fn mirror_upper(col_ptr: &[usize], row_idx: &[usize], values: &mut [f64]) {
    let n = col_ptr.len() - 1;
    for col in 0..n {
        for entry in col_ptr[col]..col_ptr[col + 1] {
            let row = row_idx[entry];
            if row <= col {
                continue;
            }
            // (row, col) lies below the diagonal: take (col, row), in column `row` (whose rows
            // are sorted).
            let column = &row_idx[col_ptr[row]..col_ptr[row + 1]];
            if let Ok(offset) = column.binary_search(&col) {
                values[entry] = values[col_ptr[row] + offset];
            }
        }
    }
}

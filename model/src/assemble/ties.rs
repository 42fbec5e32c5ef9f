//! Tied interfaces: parts meshed apart (a lining and its backplate, a friction ring and its
//! hat), held together by eliminating the DOFs of one side.
//!
//! A tie `slave -> master` names two node sets of the mesh. The master set's boundary faces
//! (those whose nodes are all in the set, one element each, any face kind) form the master
//! surface Γ_m, with its faces' shape functions N_l; every node of the slave set is tied to
//! it. Each tied node s gets weights w_sl over master nodes l, the same for x, y and z, and
//! summing to 1:
//!
//! ```text
//! u_s = Σ_l w_sl u_l
//! ```
//!
//! A tie is thus a linear combination of nodes, not of DOFs. Two methods give the weights
//! ([`TieMethod`]).
//!
//! # Collocation (`tie_method: collocation`)
//!
//! Each slave node s is projected onto Γ_m: x(ξ*) is the closest point of the nearest face
//! ([`Projector`]; ξ* clamped into the face where s lies beyond Γ_m's edge), and the node is
//! held to the surface there (code_aster's `LIAISON_MAIL`):
//!
//! ```text
//! w_sl = N_l(ξ*)          (l over the nodes of that face)
//! ```
//!
//! The shape functions are a partition of unity, so the weights sum to 1. A slave node
//! farther than `tie_distance` from Γ_m is refused: collocation assumes the surfaces meet.
//!
//! # Mortar (`tie_method: mortar`, the default)
//!
//! The slave set's boundary faces form a slave surface Γ_s, and the constraint is weak: for
//! each slave node j, with Φ_j the dual multiplier basis of [`crate::fem::mortar`]
//! (∫ Φ_j N_k = δ_jk D_jj on a fully covered linear face, Σ_j Φ_j = 1),
//!
//! ```text
//! ∫_Γs Φ_j (u_slave − u_master) dA = 0     ⇔     Σ_k S_jk u_k = Σ_l P_jl u_l
//! ```
//!
//! the rows of [`crate::fem::mortar::interface`] (S_jk = D_jk / w_j, P_jl = M_jl / w_j). S is
//! diagonal on linear faces (the covered part of a partly covered face too), so
//! u_j = Σ_l P_jl u_l; a quadratic face's mid-edge rows couple a few slave nodes, and the rows
//! are solved for them group by group, W = S⁻¹ P (S 1 = 1 and P 1 = 1, so W 1 = 1). Every
//! node of the slave set needs a row (the master surface must cover its faces), and its
//! weighted gap must be within `tie_distance`.
//!
//! # Elimination
//!
//! Let u_f gather the DOFs of the nodes that are not tied (the free ones, clamped axes left
//! out as everywhere). Every DOF of the mesh is then u = T u_f, T the identity on the free
//! nodes and w_sl I₃ on the row of a tied node s and the columns of its master l. The strain
//! and kinetic energies ½ uᵀ K u and ½ u̇ᵀ M u̇ become ½ u_fᵀ (Tᵀ K T) u_f and so on, and a
//! load's work fᵀ u becomes (Tᵀ f)ᵀ u_f:
//!
//! ```text
//! K_red = Tᵀ K T      M_red = Tᵀ M T      C_red = Tᵀ C T      f_red = Tᵀ f
//! ```
//!
//! exactly: the constraints hold identically, with no penalty to choose and no multiplier to
//! solve for, and the reduced matrices stay symmetric and positive (semi-)definite. A force on
//! a tied node goes to its masters by the same weights (`Model::add_nodal_force`); a tied
//! node's displacement is read back from its masters' (`Model::node_displacement`).
//!
//! # Why the blocks stay 3×3
//!
//! T = W ⊗ I₃, with W the node-by-node matrix of the weights (W_aa = 1 on a free node a,
//! W_sl = w_sl on a tied node s). Block by block,
//!
//! ```text
//! (Tᵀ K T)_mn = Σ_a Σ_b W_am W_bn K_ab          (each a 3×3 block)
//! ```
//!
//! so an element's block (a, b) lands on the blocks (m, n) for every master m of a and n of
//! b (a free node is its own master with weight 1), scaled by W_am W_bn. Every node of the
//! reduced model keeps its DOFs together and the pattern is still one dense 3×3 block per pair
//! of neighbouring nodes ([`super::sparse`]); the nodes of the elements at a slave node become
//! neighbours of its masters.
//!
//! # The patch test
//!
//! Constant stress σ across the interface is reproduced exactly when (i) the exact, linear
//! displacement u(x) = a + G x is in the constrained space and (ii) the tied interface
//! transmits the constant traction t = σ n consistently. Integrating by parts on each side,
//! the discrete equations differ from the exact solution's by the interface term
//!
//! ```text
//! ∫_Γ t · (v_master − v_slave) dA          for every admissible v
//! ```
//!
//! which must vanish. (i) holds for both methods when the slave nodes lie on Γ_m: every face
//! kind interpolates linear fields, so Σ_l N_l(ξ*) (a + G x_l) = a + G x_s, and for the mortar
//! rows ∫ Φ_j (u_slave − u) = 0 when both traces are the linear field itself. (ii) is where
//! they differ:
//!
//! - **Mortar** passes: t is constant and Σ_j Φ_j = 1, so the term is t · Σ_j ∫ Φ_j
//!   (v_master − v_slave) dA = 0 by the constraints themselves. Constant stress is exact to
//!   round-off on any pair of meshes whose surfaces coincide (flat faces integrate exactly).
//! - **Collocation** holds the slave nodes only: between them the slave faces (their own
//!   shape functions) and the master faces (theirs) part, and the term vanishes only where
//!   the slave trace can follow the master's exactly, on coincident meshes and on a slave
//!   side that refines the master's (each master face cut into slave faces). Elsewhere a
//!   master node receives Σ_s w_sl ∫ N_s dA of the slave side's traction instead of its own
//!   ∫ N_l dA: the stress next to the interface is off by per cents, by tens of per cents
//!   on a coarse slave over a fine master, whose nodes between the slave nodes carry nothing
//!   (see the tests). The resultant is always carried whole (Σ_l w_sl = 1). Choose the finer
//!   side as the slave, or use the mortar method.
//!
//! A rigid translation is always kept (Σ_l w_sl = 1); a rigid rotation θ only if the slave
//! nodes lie on Γ_m, a slave node at a distance d being displaced by |θ| d from where its
//! masters put it (a floating body tied across a gap then fails the equilibrium's check that
//! its rigid motions cost no energy).
//!
//! # Rules
//!
//! - A node is tied once: a node in two slave sets, or in the slave set and on the master
//!   surface of ties (the same one or another, which would chain ties), is refused, as are
//!   slave and master sets that share a node.
//! - A tied node has no DOF, so it cannot be clamped; its masters can.
//! - Contact pairs reading a tied node read its masters instead ([`Tied::substitute_pairs`]):
//!   the node is replaced in its side by its masters, weights multiplied and merged per node.
//!   A pair's pad anchor (which carries the pair's slave DOF in the stability) cannot be tied.
//! - Parts tied together are one body ([`crate::artifact::Model::bodies_of_nodes`]).
//!
//! Errors are one line naming the tie, its two sets and the figure at fault.

use std::collections::BTreeMap;
use std::fmt;

use faer::Mat;
use faer::linalg::solvers::Solve;

use crate::artifact::TiedNode;
use crate::artifact::mesh::{ContactPair, Mesh};
use crate::fem::faces::Side;
use crate::fem::mortar::{self, Projector, Row, Settings, Surface};
use crate::mesh::mortar_pairs::surface;
use crate::stage::StageError;

crate::choice! {
    /// How a tie holds its slave nodes to the master surface (module doc).
    pub enum TieMethod {
        /// Each slave node at its closest point of the master surface, u_s = Σ_l N_l(ξ*) u_l.
        Collocation = "collocation",
        /// The dual mortar rows, ∫ Φ_j (u_slave − u_master) dA = 0 for each slave node j:
        /// constant stress passes non-matching interfaces exactly.
        Mortar = "mortar",
    }
}

#[cfg(test)]
mod tests;

/// One entry of `ties`: the nodes of the set `slave` follow the surface of the set `master`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Tie {
    pub slave: String,
    pub master: String,
}

impl fmt::Display for Tie {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "`{} -> {}`", self.slave, self.master)
    }
}

/// The ties written `slave_set -> master_set`, one per entry.
pub fn parse_ties(entries: &[String]) -> Result<Vec<Tie>, StageError> {
    entries
        .iter()
        .map(|entry| {
            let parsed = entry.split_once("->").and_then(|(slave, master)| {
                let (slave, master) = (slave.trim(), master.trim());
                let valid = |name: &str| !name.is_empty() && !name.contains("->");
                (valid(slave) && valid(master)).then(|| Tie {
                    slave: slave.to_string(),
                    master: master.to_string(),
                })
            });
            parsed.ok_or_else(|| {
                StageError::new(format!(
                    "ties: `{entry}` is not `slave_set -> master_set` (two node sets of the mesh)"
                ))
            })
        })
        .collect()
}

/// The tied nodes of every tie, and what the messages and the log say of them.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tied {
    pub ties: Vec<Tie>,
    /// The tied nodes, by increasing node.
    pub nodes: Vec<TiedNode>,
    /// The tie (index into `ties`) of each of `nodes`.
    pub tie_of: Vec<usize>,
    /// Per tie: the largest distance (m) from a slave node to the master surface.
    pub largest_distance: Vec<f64>,
}

impl Tied {
    /// Whether each node of a mesh of `n_nodes` nodes is tied.
    pub fn is_tied(&self, n_nodes: usize) -> Vec<bool> {
        let mut tied = vec![false; n_nodes];
        for node in &self.nodes {
            tied[node.node as usize] = true;
        }
        tied
    }

    /// The index of `node` among the tied nodes.
    fn find(&self, node: u32) -> Option<usize> {
        self.nodes
            .binary_search_by_key(&node, |tied| tied.node)
            .ok()
    }

    /// An error if a tied node is clamped on any axis (`clamped` per node, from the entries
    /// `clamped_sets`), naming the node, its tie and the clamped set.
    pub fn refuse_clamped(
        &self,
        mesh: &Mesh,
        clamped: &[[bool; 3]],
        clamped_sets: &[String],
    ) -> Result<(), StageError> {
        let Some(index) = self
            .nodes
            .iter()
            .position(|tied| clamped[tied.node as usize].iter().any(|&axis| axis))
        else {
            return Ok(());
        };
        let node = self.nodes[index].node;
        let tie = &self.ties[self.tie_of[index]];
        let by = clamped_sets
            .iter()
            .map(|entry| {
                entry
                    .split_once(':')
                    .map_or(entry.as_str(), |(name, _)| name)
            })
            .map(str::trim)
            .find(|name| {
                mesh.node_sets
                    .get(*name)
                    .is_some_and(|set| set.contains(&node))
            })
            .unwrap_or("?");
        Err(StageError::new(format!(
            "tie {tie}: node {node} of `{}` is clamped (by `{by}`): a tied node has no DOF of its \
             own and follows `{}`; clamp the master side, or take the node out of `{}`",
            tie.slave, tie.master, tie.slave
        )))
    }

    /// Replaces each tied node of the contact pairs' sides by its masters, weights multiplied
    /// and merged per node (in order of first appearance, so the pad anchor stays first);
    /// pairs without a tied node are left as they are, bit for bit. An error if a pair's pad
    /// anchor is tied.
    pub fn substitute_pairs(&self, pairs: &mut [ContactPair]) -> Result<(), StageError> {
        if self.nodes.is_empty() {
            return Ok(());
        }
        for (index, pair) in pairs.iter_mut().enumerate() {
            if !pair.nodes().any(|node| self.find(node).is_some()) {
                continue;
            }
            let anchor = pair.pad_node();
            if let Some(tied) = self.find(anchor) {
                let tie = &self.ties[self.tie_of[tied]];
                return Err(StageError::new(format!(
                    "contact pair {index}: its pad node {anchor} (the pair's anchor, which \
                     carries its slave DOF) is tied by {tie}: contact needs nodes with DOFs of \
                     their own; tie the other way round (`{} -> {}`)",
                    tie.master, tie.slave
                )));
            }
            pair.pad = self.substitute(&pair.pad);
            pair.disc = self.substitute(&pair.disc);
        }
        Ok(())
    }

    /// `side` with each tied node replaced by its masters.
    fn substitute(&self, side: &[(u32, f64)]) -> Vec<(u32, f64)> {
        let mut merged: Vec<(u32, f64)> = Vec::with_capacity(side.len());
        let mut add = |node: u32, weight: f64| match merged.iter_mut().find(|(n, _)| *n == node) {
            Some(entry) => entry.1 += weight,
            None => merged.push((node, weight)),
        };
        for &(node, weight) in side {
            match self.find(node) {
                None => add(node, weight),
                Some(tied) => {
                    for &(master, master_weight) in &self.nodes[tied].masters {
                        add(master, weight * master_weight);
                    }
                }
            }
        }
        merged
    }
}

/// The nodes of node set `name`, checked to be in the mesh; an error names the tie.
fn node_set<'m>(mesh: &'m Mesh, tie: &Tie, name: &str) -> Result<&'m [u32], StageError> {
    let Some(nodes) = mesh.node_sets.get(name) else {
        return Err(StageError::new(format!(
            "tie {tie}: node set `{name}` is not in the mesh (the mesh has: {})",
            mesh.node_set_names()
        )));
    };
    if let Some(node) = nodes.iter().find(|&&node| node as usize >= mesh.n_nodes()) {
        return Err(StageError::new(format!(
            "tie {tie}: node set `{name}` names node {node}, but the mesh has {} nodes",
            mesh.n_nodes()
        )));
    }
    Ok(nodes)
}

/// The tied nodes of the ties `entries` (`slave_set -> master_set`) by `method`, each slave
/// node at most `tie_distance` (m) from its master surface (module doc). No entries, no ties.
pub fn tie_nodes(
    mesh: &Mesh,
    entries: &[String],
    tie_distance: f64,
    method: TieMethod,
) -> Result<Tied, StageError> {
    let ties = parse_ties(entries)?;
    if ties.is_empty() {
        return Ok(Tied::default());
    }
    if !(tie_distance >= 0.0 && tie_distance.is_finite()) {
        return Err(StageError::new(format!(
            "tie_distance must be a finite length ≥ 0, not {tie_distance}"
        )));
    }
    // Sets, overlaps and surfaces, all checked before any projection.
    let mut slave_of: BTreeMap<u32, usize> = BTreeMap::new();
    let mut surfaces = Vec::with_capacity(ties.len());
    for (index, tie) in ties.iter().enumerate() {
        let slaves = node_set(mesh, tie, &tie.slave)?;
        let masters = node_set(mesh, tie, &tie.master)?;
        if slaves.is_empty() {
            return Err(StageError::new(format!(
                "tie {tie}: slave set `{}` has no node",
                tie.slave
            )));
        }
        let side = Side::new(&tie.master, masters.iter().copied());
        if let Some(shared) = slaves.iter().find(|&&node| side.contains(node)) {
            return Err(StageError::new(format!(
                "tie {tie}: node {shared} is in both `{}` and `{}`: the slave and master sets \
                 must not overlap (a node cannot follow itself)",
                tie.slave, tie.master
            )));
        }
        for &node in slaves {
            if let Some(&other) = slave_of.get(&node) {
                if other != index {
                    return Err(StageError::new(format!(
                        "node {node} is tied twice, by {} and by {tie}: a node follows one \
                         master surface",
                        ties[other]
                    )));
                }
            } else {
                slave_of.insert(node, index);
            }
        }
        let master_surface = surface(mesh, &side);
        if master_surface.faces.is_empty() {
            return Err(StageError::new(format!(
                "tie {tie}: master set `{}` holds no boundary face (all the nodes of one \
                 element face), so `{}` has no surface to follow",
                tie.master, tie.slave
            )));
        }
        surfaces.push(master_surface);
    }
    for (index, master_surface) in surfaces.iter().enumerate() {
        let tie = &ties[index];
        for &node in master_surface.faces.iter().flat_map(|(_, nodes)| nodes) {
            if let Some(&other) = slave_of.get(&node) {
                return Err(StageError::new(format!(
                    "node {node} is tied by {} (a node of `{}`) and is a master of {tie} (a \
                     node of `{}`'s surface): chains of ties are refused, tie both to one master",
                    ties[other], ties[other].slave, tie.master
                )));
            }
        }
    }

    let mut nodes: Vec<(TiedNode, usize)> = Vec::with_capacity(slave_of.len());
    let mut largest_distance = vec![0.0f64; ties.len()];
    for (index, (tie, master_surface)) in ties.iter().zip(&surfaces).enumerate() {
        let slaves = &mesh.node_sets[&tie.slave];
        let (tied, distance) = match method {
            TieMethod::Collocation => collocate(mesh, tie, master_surface, tie_distance)?,
            TieMethod::Mortar => mortar_rows(mesh, tie, master_surface, tie_distance)?,
        };
        largest_distance[index] = distance;
        nodes.extend(tied.into_iter().map(|tied| (tied, index)));
        tracing::info!(
            "tie {tie} ({method}): {} nodes of `{}` tied to {} faces of `{}`, the farthest \
             {distance:.3e} m away",
            slaves.len(),
            tie.slave,
            master_surface.faces.len(),
            tie.master,
        );
    }
    nodes.sort_by_key(|(tied, _)| tied.node);
    let (nodes, tie_of) = nodes.into_iter().unzip();
    Ok(Tied {
        ties,
        nodes,
        tie_of,
        largest_distance,
    })
}

/// Collocation: each node of the slave set at its closest point of `master_surface`, with the
/// shape functions there as weights; and the largest distance.
fn collocate(
    mesh: &Mesh,
    tie: &Tie,
    master_surface: &Surface,
    tie_distance: f64,
) -> Result<(Vec<TiedNode>, f64), StageError> {
    let projector = Projector::new(&mesh.nodes, master_surface, tie_distance)
        .map_err(|err| StageError::new(format!("tie {tie}: {err}")))?;
    let slaves = &mesh.node_sets[&tie.slave];
    let mut missed = Vec::new();
    let mut tied = Vec::with_capacity(slaves.len());
    let mut largest: f64 = 0.0;
    for &node in slaves {
        let Some(projection) = projector.project(mesh.nodes[node as usize]) else {
            missed.push(node);
            continue;
        };
        largest = largest.max(projection.distance);
        let masters: Vec<(u32, f64)> = projection
            .weights
            .into_iter()
            .filter(|&(_, weight)| weight != 0.0)
            .collect();
        tied.push(TiedNode { node, masters });
    }
    if !missed.is_empty() {
        return Err(missed_error(
            mesh,
            tie,
            &projector,
            &missed,
            slaves.len(),
            tie_distance,
        ));
    }
    Ok((tied, largest))
}

/// The dual mortar rows of the slave set's faces against `master_surface`
/// ([`crate::fem::mortar`]): Σ_k S_jk u_k = Σ_l P_jl u_l for each slave node j, solved for the
/// slave nodes, u_s = (S⁻¹ P) u_m (S is the identity on fully covered linear faces; a
/// quadratic face's mid-edge rows and partly covered faces couple a few slave nodes, solved
/// group by group). Every node of the slave set needs a row, within `tie_distance` (its
/// weighted gap) of the master surface. Returns the tied nodes and the largest |gap|.
fn mortar_rows(
    mesh: &Mesh,
    tie: &Tie,
    master_surface: &Surface,
    tie_distance: f64,
) -> Result<(Vec<TiedNode>, f64), StageError> {
    let slaves = &mesh.node_sets[&tie.slave];
    let slave_surface = surface(mesh, &Side::new(&tie.slave, slaves.iter().copied()));
    if slave_surface.faces.is_empty() {
        return Err(StageError::new(format!(
            "tie {tie}: slave set `{}` holds no boundary face (all the nodes of one element \
             face), which the mortar method integrates over (collocation ties nodes alone)",
            tie.slave
        )));
    }
    // Faces a little farther than the tie distance are paired too, so that a gap too wide
    // is named with its figure below rather than as faces that do not overlap.
    let settings = Settings {
        search_distance: 10.0 * tie_distance,
        ..Settings::default()
    };
    let interface = mortar::interface(&mesh.nodes, &slave_surface, master_surface, &settings)
        .map_err(|err| StageError::new(format!("tie {tie}: {err}")))?;
    let row_of: BTreeMap<u32, usize> = interface
        .rows
        .iter()
        .enumerate()
        .map(|(index, row)| (row.node, index))
        .collect();
    let uncovered: Vec<u32> = slaves
        .iter()
        .copied()
        .filter(|node| !row_of.contains_key(node))
        .collect();
    if let Some(first) = uncovered.first() {
        return Err(StageError::new(format!(
            "tie {tie}: {} of the {} nodes of `{}` are not covered by the surface of `{}` within \
             tie_distance = {tie_distance:.3e} m (the first node {first}): the mortar method \
             ties nodes whose faces the master surface covers",
            uncovered.len(),
            slaves.len(),
            tie.slave,
            tie.master
        )));
    }
    if let Some(row) = interface
        .rows
        .iter()
        .filter(|row| !(row.gap.abs() <= tie_distance))
        .max_by(|a, b| a.gap.abs().total_cmp(&b.gap.abs()))
    {
        let farther = interface
            .rows
            .iter()
            .filter(|row| !(row.gap.abs() <= tie_distance))
            .count();
        return Err(StageError::new(format!(
            "tie {tie}: node {} of `{}` is {:.3e} m from the surface of `{}`, farther than \
             tie_distance = {tie_distance:.3e} m ({farther} of the {} nodes of `{}` are farther)",
            row.node,
            tie.slave,
            row.gap.abs(),
            tie.master,
            slaves.len(),
            tie.slave
        )));
    }
    let largest = interface
        .rows
        .iter()
        .map(|row| row.gap.abs())
        .fold(0.0, f64::max);
    // Groups of slave nodes coupled by S, each solved on its own.
    let n_rows = interface.rows.len();
    let mut parent: Vec<usize> = (0..n_rows).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for (index, row) in interface.rows.iter().enumerate() {
        // Every slave node has a row (checked above), so every node of S is found.
        for other in row.slave.iter().filter_map(|(node, _)| row_of.get(node)) {
            let other = *other;
            let (a, b) = (root(&mut parent, index), root(&mut parent, other));
            if a != b {
                parent[b.max(a)] = a.min(b);
            }
        }
    }
    let mut groups: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for index in 0..n_rows {
        groups
            .entry(root(&mut parent, index))
            .or_default()
            .push(index);
    }
    let mut tied = Vec::with_capacity(n_rows);
    for group in groups.values() {
        let rows: Vec<&Row> = group.iter().map(|&index| &interface.rows[index]).collect();
        if let [row] = rows[..] {
            // S_jj = 1: u_j = Σ_l P_jl u_l.
            tied.push(TiedNode {
                node: row.node,
                masters: row.master.clone(),
            });
            continue;
        }
        let local: BTreeMap<u32, usize> = rows
            .iter()
            .enumerate()
            .map(|(i, row)| (row.node, i))
            .collect();
        let mut masters: Vec<u32> = rows
            .iter()
            .flat_map(|row| row.master.iter().map(|&(node, _)| node))
            .collect();
        masters.sort_unstable();
        masters.dedup();
        let k = rows.len();
        let mut S = Mat::<f64>::zeros(k, k);
        let mut P = Mat::<f64>::zeros(k, masters.len());
        for (i, row) in rows.iter().enumerate() {
            for &(node, weight) in &row.slave {
                if let Some(&column) = local.get(&node) {
                    S[(i, column)] += weight;
                }
            }
            for &(node, weight) in &row.master {
                let Ok(l) = masters.binary_search(&node) else {
                    continue;
                };
                P[(i, l)] += weight;
            }
        }
        let W = S.partial_piv_lu().solve(&P);
        if !(0..k).all(|i| (0..masters.len()).all(|l| W[(i, l)].is_finite())) {
            return Err(StageError::new(format!(
                "tie {tie}: the mortar rows of nodes {:?}… of `{}` cannot be solved for them \
                 (singular); tie with `tie_method: collocation`",
                &rows.iter().map(|row| row.node).take(4).collect::<Vec<_>>(),
                tie.slave
            )));
        }
        for (i, row) in rows.iter().enumerate() {
            let weights: Vec<(u32, f64)> = masters
                .iter()
                .enumerate()
                .map(|(l, &master)| (master, W[(i, l)]))
                .filter(|&(_, weight)| weight != 0.0)
                .collect();
            tied.push(TiedNode {
                node: row.node,
                masters: weights,
            });
        }
    }
    Ok((tied, largest))
}

/// The error for the slave nodes `missed` that found no master face within `tie_distance`:
/// the farthest of them by its distance, or, if none has a closest point at all, their count.
fn missed_error(
    mesh: &Mesh,
    tie: &Tie,
    projector: &Projector,
    missed: &[u32],
    n_slaves: usize,
    tie_distance: f64,
) -> StageError {
    let mut farthest: Option<(f64, u32)> = None;
    let mut nowhere = Vec::new();
    for &node in missed {
        match projector.nearest(mesh.nodes[node as usize]) {
            Some(projection) => {
                if farthest.is_none_or(|(distance, _)| projection.distance > distance) {
                    farthest = Some((projection.distance, node));
                }
            }
            None => nowhere.push(node),
        }
    }
    match farthest {
        Some((distance, node)) => StageError::new(format!(
            "tie {tie}: node {node} of `{}` is {distance:.3e} m from the surface of `{}`, farther \
             than tie_distance = {tie_distance:.3e} m ({} of the {n_slaves} nodes of `{}` are \
             farther)",
            tie.slave,
            tie.master,
            missed.len() - nowhere.len(),
            tie.slave
        )),
        None => StageError::new(format!(
            "tie {tie}: {} of the {n_slaves} nodes of `{}` project nowhere on the surface of \
             `{}` (the closest-point iteration fails on every face: distorted faces?), the first \
             node {}",
            nowhere.len(),
            tie.slave,
            tie.master,
            nowhere[0]
        )),
    }
}

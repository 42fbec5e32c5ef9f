//! Frictional contact between the disc and the pads (`docs/science.md` §2–3).
//!
//! Conventions, used everywhere in squeal:
//! - A pair ([`ContactPair`](crate::artifact::ContactPair)) is a point of the pad's face,
//!   x_p = Σ_k S_k x_k over pad nodes k, facing a point of the disc's face, x_d = Σ_l P_l x_l
//!   over disc nodes l, each side's weights summing to 1. Node to node (conforming meshes) is
//!   one node of weight 1 per side, coincident at rest; a mortar row is slave (pad) node j with
//!   its weights S_jk against the master (disc) nodes l with P_jl. The pad side's first node is
//!   the pair's anchor (tables, the stability's slave DOF, the pair's body).
//! - Its normal n is the disc's outward normal (from the disc into the pad); t is the direction
//!   of the disc's sliding velocity v_g = ω e_z × x_d projected on the contact plane; b = n × t.
//! - The relative displacement is δ = Σ_k S_k u_k − Σ_l P_l u_l (u_p − u_d node to node); its
//!   normal part δ_n = n·δ; the gap is g = g₀ + δ_n ≥ 0, g₀ = n·(x_p − x_d) from the geometry
//!   minus any imposed interference.
//! - The reaction r is the force the disc exerts on the pad point, (r_n, r_t, r_b) in the local
//!   frame: pad node k receives S_k r, disc node l receives −P_l r (Hᵀ r).
//!   **r_n ≥ 0 is compression** (the paper writes r_n ≤ 0).
//! - Sliding friction drags the pad along the disc's motion: r_t = μ r_n, r_b = 0.

pub mod lcp;
pub mod pad_face;

use crate::artifact::ContactFrames;
use crate::artifact::Model;
use crate::artifact::mesh::{ContactPair, Mesh, cross, dot};

/// Frames for a disc spinning at `omega` (rad/s) about the z axis through the origin.
pub fn frames(mesh: &Mesh, omega: f64) -> Result<ContactFrames, String> {
    let mut frames = ContactFrames {
        n: Vec::new(),
        t: Vec::new(),
        b: Vec::new(),
        sliding_speed: Vec::new(),
    };
    for (pair_idx, pair) in mesh.contact_pairs.iter().enumerate() {
        let x = pair.disc_position(&mesh.nodes);
        let n = pair.normal;
        let v_g = cross([0.0, 0.0, omega], x);
        // Tangential part of the sliding velocity: the disc moves within its own surface.
        let normal_part = dot(v_g, n);
        let tangential = [
            v_g[0] - normal_part * n[0],
            v_g[1] - normal_part * n[1],
            v_g[2] - normal_part * n[2],
        ];
        let speed = dot(tangential, tangential).sqrt();
        let tiny = 1e-12 * omega.abs() * dot(x, x).sqrt();
        if speed.is_nan() || speed <= tiny || !speed.is_finite() {
            let node = match pair.single_disc_node() {
                Some(disc_node) => format!("disc node {disc_node}"),
                None => format!("pad node {}", pair.pad_node()),
            };
            return Err(format!(
                "contact pair {pair_idx} ({node}) has no sliding direction: |v_g| = {speed:.3e} m/s at ω = {omega} rad/s"
            ));
        }
        let t = tangential.map(|component| component / speed);
        frames.b.push(cross(n, t));
        frames.n.push(n);
        frames.t.push(t);
        frames.sliding_speed.push(speed);
    }
    Ok(frames)
}

/// Hᵀ column by column: for pair p and local direction d (0 = n, 1 = t, 2 = b), column
/// 3p + d holds S_k e_d on each pad node k's free DOFs and −P_l e_d on each disc node l's, the
/// entries of one DOF merged (in order of first appearance, pad side first), so that
/// (H u)_{3p+d} = e_d · (Σ_k S_k u_k − Σ_l P_l u_l) and Hᵀ r is the generalized contact force.
/// Node to node the column is e_d on the pad node's DOFs, −e_d on the disc node's.
pub fn h_columns(model: &Model, frames: &ContactFrames) -> Vec<Vec<(usize, f64)>> {
    let mut columns = Vec::with_capacity(3 * frames.n.len());
    for (pair_idx, pair) in model.mesh.contact_pairs.iter().enumerate() {
        for direction in [frames.n[pair_idx], frames.t[pair_idx], frames.b[pair_idx]] {
            let mut column: Vec<(usize, f64)> =
                Vec::with_capacity(3 * (pair.pad.len() + pair.disc.len()));
            for (node, weight) in pair.signed_weights() {
                for (axis, dof) in model.dof_of_node[node as usize].iter().enumerate() {
                    if let Some(dof) = dof
                        && direction[axis] != 0.0
                        && weight != 0.0
                    {
                        let (dof, value) = (*dof as usize, weight * direction[axis]);
                        match column.iter_mut().find(|(other, _)| *other == dof) {
                            Some(entry) => entry.1 += value,
                            None => column.push((dof, value)),
                        }
                    }
                }
            }
            columns.push(column);
        }
    }
    columns
}

/// The geometric gap of a pair along `normal`, g₀ = n·(x_p − x_d) with the weighted positions
/// of [`ContactPair::pad_position`] and [`ContactPair::disc_position`].
pub fn initial_gap(pair: &ContactPair, nodes: &[[f64; 3]], normal: [f64; 3]) -> f64 {
    let (x_pad, x_disc) = (pair.pad_position(nodes), pair.disc_position(nodes));
    (0..3)
        .map(|axis| (x_pad[axis] - x_disc[axis]) * normal[axis])
        .sum()
}

#[cfg(test)]
mod tests;

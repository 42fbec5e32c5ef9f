//! Frictional contact between the disc and the pads (`docs/science.md` §2–3).
//!
//! Conventions, used everywhere in squeal:
//! - A pair is (disc node d, pad node p), coincident at rest. Its normal n is the disc's
//!   outward normal (from the disc into the pad); t is the direction of the disc's sliding
//!   velocity v_g = ω e_z × x_d projected on the contact plane; b = n × t.
//! - The relative displacement is δ = u_p − u_d; its normal part δ_n = n·δ; the gap is
//!   g = g₀ + δ_n ≥ 0 (g₀ from the geometry, minus any imposed interference).
//! - The reaction r is the force the disc exerts on the pad node, (r_n, r_t, r_b) in the local
//!   frame; the disc node receives −r. **r_n ≥ 0 is compression** (the paper writes r_n ≤ 0).
//! - Sliding friction drags the pad along the disc's motion: r_t = μ r_n, r_b = 0.

pub mod lcp;

use crate::artifact::ContactFrames;
use crate::artifact::Model;
use crate::artifact::mesh::{Mesh, cross, dot};

/// Frames for a disc spinning at `omega` (rad/s) about the z axis through the origin.
pub fn frames(mesh: &Mesh, omega: f64) -> Result<ContactFrames, String> {
    let mut frames = ContactFrames {
        n: Vec::new(),
        t: Vec::new(),
        b: Vec::new(),
        sliding_speed: Vec::new(),
    };
    for (pair_idx, pair) in mesh.contact_pairs.iter().enumerate() {
        let x = mesh.nodes[pair.disc_node as usize];
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
            return Err(format!(
                "contact pair {pair_idx} (disc node {}) has no sliding direction: |v_g| = {speed:.3e} m/s at ω = {omega} rad/s",
                pair.disc_node
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
/// 3p + d holds e_d on the pad node's free DOFs and −e_d on the disc node's, so that
/// (H u)_{3p+d} = e_d · (u_pad − u_disc) and Hᵀ r is the generalized contact force.
pub fn h_columns(model: &Model, frames: &ContactFrames) -> Vec<Vec<(usize, f64)>> {
    let mut columns = Vec::with_capacity(3 * frames.n.len());
    for (pair_idx, pair) in model.mesh.contact_pairs.iter().enumerate() {
        for direction in [frames.n[pair_idx], frames.t[pair_idx], frames.b[pair_idx]] {
            let mut column = Vec::with_capacity(6);
            for (node, sign) in [(pair.pad_node, 1.0), (pair.disc_node, -1.0)] {
                for (axis, dof) in model.dof_of_node[node as usize].iter().enumerate() {
                    if let Some(dof) = dof
                        && direction[axis] != 0.0
                    {
                        column.push((*dof as usize, sign * direction[axis]));
                    }
                }
            }
            columns.push(column);
        }
    }
    columns
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::brake::{BrakeGeometry, brake};

    #[test]
    fn frames_follow_the_rotation_and_are_orthonormal() {
        let geometry = BrakeGeometry::coarse();
        let mesh = brake(&geometry).unwrap();
        let omega = 4.0;
        let frames = super::frames(&mesh, omega).unwrap();
        for (pair_idx, pair) in mesh.contact_pairs.iter().enumerate() {
            let x = mesh.nodes[pair.disc_node as usize];
            let radius = (x[0] * x[0] + x[1] * x[1]).sqrt();
            assert!((frames.sliding_speed[pair_idx] - omega * radius).abs() < 1e-12);
            let (n, t, b) = (frames.n[pair_idx], frames.t[pair_idx], frames.b[pair_idx]);
            for (u, v, expected) in [
                (n, n, 1.0),
                (t, t, 1.0),
                (b, b, 1.0),
                (n, t, 0.0),
                (n, b, 0.0),
                (t, b, 0.0),
            ] {
                assert!((dot(u, v) - expected).abs() < 1e-14);
            }
            // t is along e_z × x: counter-clockwise seen from +z for ω > 0.
            assert!((t[0] * -x[1] + t[1] * x[0]) / radius > 1.0 - 1e-14);
        }
        assert!(
            super::frames(&mesh, 0.0)
                .unwrap_err()
                .contains("has no sliding direction")
        );
    }
}
